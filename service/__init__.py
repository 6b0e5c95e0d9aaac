"""plotgate service: FastAPI app, wire schemas, operation registry and MCAP recorder.

Nothing is imported here on purpose: clients import :mod:`service.schemas` (pydantic
only) and replay imports :mod:`service.registry` (schemas and core) without pulling in
FastAPI. The app lives in :mod:`service.app`.
"""
