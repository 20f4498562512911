"""The job service (FastAPI): robots, jobs, progress as server-sent events, the operator's
go-ahead, abort, measurements, results and a report page.

`create_app(settings)` builds the app; nothing is created at import. Every request but signing
in carries `Authorization: Bearer <token>` (401 without, 403 with one nobody has or whose user's
role lacks the route's grant: service/roles.py); every change and refusal is audited
(service/audit.py). The routes are in `service/api/`, one router per
resource.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from swagger_ui_bundle import swagger_ui_path

from screwcal.runtime.policy import held_for_service
from service.api import events, history, jobs, people, robots
from service.api.audit_middleware import AuditMiddleware
from service.api.errors import install_error_handlers
from service.audit import AuditTrail
from service.manager import JobManager
from service.people import People
from service.settings import ServiceSettings
from service.sign_in_limit import SignInLimit
from service.store import Store, open_store


def create_app(settings: ServiceSettings, store: Store | None = None,
               on_fatal: Callable[[str], None] | None = None) -> FastAPI:
    """The app; `store` an already opened store (the service opens it before it binds, so that
    a database another service holds is refused at once), `on_fatal` what stops the service when
    its database is lost (the server's shutdown; without it, requests then get 503)."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        own = store if store is not None else await asyncio.to_thread(open_store, settings)
        manager = JobManager(own, settings, on_fatal=on_fatal)
        app.state.store, app.state.manager, app.state.settings = own, manager, settings
        app.state.people, app.state.audit = People(own.db), AuditTrail(own.db)
        app.state.sign_in_limit = SignInLimit()
        app.state.planning = set()  # robots whose job is being planned by a request now
        app.state.plans = asyncio.Semaphore(settings.max_concurrent_plans)
        await manager.resume_unfinished()
        # one BLAS thread for the service's whole life (jobs call BLAS in many worker threads
        # at once), the heap kept: the process's policy, at its door (screwcal/runtime/policy.py)
        with held_for_service():
            yield
            await manager.stop()
        await asyncio.to_thread(own.close)

    app = FastAPI(title="screwcal job service", version="1", lifespan=lifespan,
                  docs_url=None, redoc_url=None,
                  description="Sequences performance and calibration pose lists, persists every "
                              "measurement, runs the estimation per job (mm and degrees).")
    _serve_docs(app)
    install_error_handlers(app)
    app.include_router(robots.router)
    app.include_router(history.router)
    app.include_router(jobs.router)
    app.include_router(events.router)
    app.include_router(people.router)
    app.add_middleware(AuditMiddleware)
    return app


def _serve_docs(app: FastAPI) -> None:
    """/docs from the files installed with the package: a cell network has no internet."""
    app.mount("/static/swagger", StaticFiles(directory=str(swagger_ui_path)), name="swagger")
    app.openapi_version = "3.0.3"  # what the bundled Swagger UI (4.15) renders

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return get_swagger_ui_html(openapi_url=str(app.openapi_url), title=f"{app.title} - docs",
                                   swagger_js_url="/static/swagger/swagger-ui-bundle.js",
                                   swagger_css_url="/static/swagger/swagger-ui.css",
                                   swagger_favicon_url="/static/swagger/favicon-32x32.png")
