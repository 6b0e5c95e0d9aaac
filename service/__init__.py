"""plotgate service: FastAPI app, wire schemas, operation registry and MCAP recorder.

Nothing is imported here on purpose: clients import :mod:`plotgate.service.schemas` (pydantic
only) and replay imports :mod:`plotgate.service.registry` (schemas and core) without pulling in
FastAPI. The app lives in :mod:`plotgate.service.app`.
"""
