"""``POST /v1/bounds``: bounds on the critical probability and on ``E[P]``, as ``kfio bounds --json``."""

from .report import report_router

router = report_router(
    "/v1/bounds",
    job="bounds",
    schema="BoundsReport",
    summary="Bounds on the critical probability and on the expected covariance (Liu and Goldsmith 2004; Rohr, Marelli and Fu 2010; Sinopoli et al. 2004)",
    description="The classical bounds: closed-form lower, certified LMI upper, S_bar <= lim E[P_t] <= V_bar.",
)
