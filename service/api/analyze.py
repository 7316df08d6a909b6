"""``POST /v1/analyze``: the exact stability verdict, as ``kfio analyze --json`` prints it."""

from .report import report_router

router = report_router(
    "/v1/analyze",
    job="analyze",
    schema="StabilityReport",
    summary="Exact stability verdict (Rohr, Marelli and Fu 2014, Theorem 1)",
    description="Decides whether the expected error covariance of the Kalman filter stays bounded.",
)
