"""The OpenAPI document and the pages that show it, served with no network.

* :func:`openapi` builds ``/openapi.json``: FastAPI's description of the ops routes
  (health, metrics), plus one path per registry operation, built from the same registry
  that serves them (:class:`plotgate.service.routes.Operations` answers them as pure ASGI,
  not as FastAPI routes). Each operation has its request model with its example body
  (its declaration's, :mod:`plotgate.service.table`), its result model, problem+json for
  every error status, and ``x-plotgate-limits``: the sizes a server may cap and this
  server's caps (null: only the schema's own bounds).
* When a key or a token is set, the document declares the schemes with FastAPI's own
  security classes (:class:`fastapi.security.APIKeyHeader` for ``X-API-Key``,
  :class:`fastapi.security.HTTPBearer`) and requires one of them on every path but the
  open ones, so ``/docs`` has an Authorize button. The guard that checks them is
  :class:`plotgate.service.guards.Auth`.
* :func:`docs_router` serves ``/docs`` (Swagger UI) and ``/redoc`` with their scripts and
  styles from the ``fastapi-offline`` package under ``/docs/assets``, not from a CDN, so
  the docs work on a machine with no internet, as radar sites often are.
"""

import json
from importlib.resources import files
from pathlib import Path
from typing import Any, Literal

from fastapi import APIRouter, FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.openapi.utils import get_openapi
from fastapi.responses import HTMLResponse
from fastapi.security import APIKeyHeader, HTTPBearer
from pydantic import BaseModel
from pydantic.json_schema import models_json_schema

from plotgate.service.config import Settings
from plotgate.service.guards import OPEN_PATHS
from plotgate.service.registry import OPERATIONS
from plotgate.service.routes import PROBLEM_JSON
from plotgate.service.schemas import Endpoint, Problem

__all__ = ["ASSETS_PATH", "assets_folder", "docs_router", "openapi"]

ASSETS_PATH = "/docs/assets"
"""Where Swagger UI's and ReDoc's scripts, styles and icon are served."""

API_KEY = APIKeyHeader(
    name="X-API-Key",
    scheme_name="ApiKey",
    description="The key set as PLOTGATE_API_KEY.",
    auto_error=False,
)
BEARER = HTTPBearer(
    scheme_name="Bearer",
    description="The token set as PLOTGATE_BEARER_TOKEN.",
    auto_error=False,
)

_PROBLEMS = {
    "400": "The body is not JSON.",
    "408": "The body did not arrive within the server's deadline.",
    "413": "The body is over the server's size limit (PLOTGATE_MAX_BODY_BYTES).",
    "422": "A field is invalid; `errors` names each one.",
    "503": "The exchange could not be recorded, so it was refused; or the Dask "
    "cluster of a Monte Carlo could not be reached; retry after `Retry-After` seconds.",
    "504": "The Monte Carlo did not finish on the Dask cluster within the server's "
    "timeout (PLOTGATE_DASK_TIMEOUT_S); its work was cancelled.",
}
_UNAUTHORIZED = "The credentials are missing or wrong (`WWW-Authenticate` says which)."


def assets_folder() -> Path:
    """The folder of Swagger UI's and ReDoc's files in the installed ``fastapi-offline``."""
    return Path(str(files("fastapi_offline") / "static"))


def openapi(app: FastAPI) -> dict[str, Any]:
    """The app's OpenAPI document, built once."""
    if app.openapi_schema:
        return app.openapi_schema
    settings: Settings = app.state.settings
    schema = get_openapi(
        title=app.title, version=app.version, summary=app.summary, routes=app.routes
    )
    paths, models = _operations(settings)
    schema["paths"] = {**paths, **schema["paths"]}
    schema.setdefault("components", {}).setdefault("schemas", {}).update(models)
    schemes = _security_schemes(settings)
    if schemes:
        schema["components"]["securitySchemes"] = schemes
        required: list[dict[str, list[str]]] = [{name: []} for name in schemes]
        for path, item in schema["paths"].items():
            if path not in OPEN_PATHS:
                for operation in item.values():
                    operation["security"] = required
                    operation["responses"]["401"] = _problem(_UNAUTHORIZED)
    app.openapi_schema = schema
    return schema


def _operations(settings: Settings) -> tuple[dict[str, Any], dict[str, Any]]:
    """The registry's paths, and the schemas of their models (requests as validated,
    results as serialized)."""
    models: list[tuple[type[BaseModel], Literal["validation", "serialization"]]] = [
        (Problem, "serialization")
    ]
    for op in OPERATIONS.values():
        models += [(op.request, "validation"), (op.response, "serialization")]
    refs, top = models_json_schema(models, ref_template="#/components/schemas/{model}")
    paths: dict[str, Any] = {}
    for op in OPERATIONS.values():
        post: dict[str, Any] = {
            "tags": [op.endpoint.tag],
            "summary": op.endpoint.summary,
            "description": _description(op.endpoint),
            "operationId": op.name,
            "requestBody": {
                "required": True,
                "content": {
                    "application/json": {
                        "schema": refs[op.request, "validation"],
                        "example": op.endpoint.example,
                    }
                },
            },
            "responses": {
                "200": {
                    "description": "Successful Response",
                    "content": {
                        "application/json": {"schema": refs[op.response, "serialization"]}
                    },
                },
                **{status: _problem(text) for status, text in _PROBLEMS.items()},
            },
        }
        if op.endpoint.work:
            caps = settings.limits.get(op.name, {})
            post["x-plotgate-limits"] = {size: caps.get(size) for size in op.endpoint.work}
        paths[op.path] = {"post": post}
    return paths, top.get("$defs", {})


def _description(endpoint: Endpoint) -> str:
    """The operation's description, then its example request as compact JSON: every
    operation shows one, also where a viewer hides the request body's example."""
    example = json.dumps(endpoint.example, separators=(",", ":"))
    return f"{endpoint.description}\n\nExample request:\n\n```json\n{example}\n```"


def _problem(description: str) -> dict[str, Any]:
    return {
        "description": description,
        "content": {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }


def _security_schemes(settings: Settings) -> dict[str, Any]:
    """The schemes this server checks: none when no key and no token are set."""
    enabled = [
        scheme
        for scheme, on in ((API_KEY, settings.api_key), (BEARER, settings.bearer_token))
        if on is not None
    ]
    return {
        scheme.scheme_name: jsonable_encoder(scheme.model, by_alias=True, exclude_none=True)
        for scheme in enabled
    }


def docs_router(title: str, openapi_url: str = "/openapi.json") -> APIRouter:
    """``/docs`` and ``/redoc``, their scripts from :data:`ASSETS_PATH` (mounted by the app
    on :func:`assets_folder`); every URL in the pages under the app's root path, as
    FastAPI's own pages do, so they work behind a proxy that strips a prefix."""
    router = APIRouter(include_in_schema=False)

    @router.get("/docs")
    async def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_swagger_ui_html(
            openapi_url=root + openapi_url,
            title=f"{title} - Swagger UI",
            swagger_js_url=f"{root}{ASSETS_PATH}/swagger-ui-bundle.js",
            swagger_css_url=f"{root}{ASSETS_PATH}/swagger-ui.css",
            swagger_favicon_url=f"{root}{ASSETS_PATH}/favicon.png",
            oauth2_redirect_url=f"{root}/docs/oauth2-redirect",
        )

    @router.get("/docs/oauth2-redirect")
    async def oauth2_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @router.get("/redoc")
    async def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_redoc_html(
            openapi_url=root + openapi_url,
            title=f"{title} - ReDoc",
            redoc_js_url=f"{root}{ASSETS_PATH}/redoc.standalone.js",
            redoc_favicon_url=f"{root}{ASSETS_PATH}/favicon.png",
            with_google_fonts=False,
        )

    return router
