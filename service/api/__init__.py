"""HTTP routes, one module per resource (analyze, bounds, simulate, loop, fit, plots, jobs, health, sweeps, schemas)."""

from fastapi import APIRouter

from . import analyze, bounds, fit, health, jobs, json_schemas, loop, plots, simulate, sweeps

api_router = APIRouter()
for _module in (health, analyze, bounds, simulate, loop, fit, plots, jobs, sweeps, json_schemas):
    api_router.include_router(_module.router)

__all__ = ["api_router"]
