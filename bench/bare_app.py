"""The peer of ``bench/bench_service.py``: a bare FastAPI app doing plotgate's work.

One route, ``POST /v1/gates/test``, does the same work as plotgate's and nothing else: a
strict pydantic parse of the same request model, the same operation handler, the answer
serialized to JSON. No request ids, no guards, no metrics, no recording, no problem
bodies. It is what a FastAPI service of the same operation costs, so the difference to
plotgate is what plotgate adds around the work.

    uvicorn --factory bench.bare_app:create_app --port 8001
"""

from fastapi import FastAPI, Request, Response

from plotgate.service.registry import OPERATIONS

__all__ = ["create_app"]


def create_app() -> FastAPI:
    """The bare app: one gate-test route."""
    app = FastAPI()
    op = OPERATIONS["gates.test"]
    handler = op.handler  # imported (and its kernels loaded) now, as the service does

    @app.post("/v1/gates/test")
    async def test(request: Request) -> Response:
        parsed = op.request.model_validate_json(await request.body(), strict=True)
        answer = handler(parsed).model_dump_json().encode()
        return Response(answer, media_type="application/json")

    return app
