"""``POST /v1/simulate``: Monte Carlo error bands, as ``kfio simulate --json``."""

from .report import report_router

router = report_router(
    "/v1/simulate",
    job="simulate",
    schema="SimulationReport",
    summary="Simulated error covariance bands",
    description="Monte Carlo statistics of trace(P_t) over the lossy channel (options.simulate).",
)
