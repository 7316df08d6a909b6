"""HTTP routes, one module per resource (analyze, bounds, simulate, plots, jobs, health)."""

from fastapi import APIRouter

from . import analyze, bounds, health, jobs, loop, plots, simulate, sweeps

api_router = APIRouter()
for _module in (health, analyze, bounds, simulate, loop, plots, jobs, sweeps):
    api_router.include_router(_module.router)

__all__ = ["api_router"]
