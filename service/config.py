"""Service settings, read from ``PLOTGATE_*`` environment variables (or a ``.env`` file)."""

from functools import lru_cache
from pathlib import Path

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from plotgate.service.schemas import MEMORY_BUDGET_MIB, TIME_BUDGET_S
from plotgate.service.table import work_caps

__all__ = ["Settings", "get_settings"]


class Settings(BaseSettings):
    """Everything an operator can set; each field is ``PLOTGATE_<NAME>`` in the environment."""

    model_config = SettingsConfigDict(env_prefix="PLOTGATE_", env_file=".env", extra="ignore")

    host: str = Field(default="127.0.0.1", description="Address to listen on.")
    port: int = Field(default=8000, ge=1, le=65535)
    workers: int = Field(default=1, ge=1, description="uvicorn worker processes.")
    record: bool = Field(default=True, description="Record every exchange to MCAP.")
    record_best_effort: bool = Field(
        default=False,
        description="Answer even when a record cannot be written (counted in "
        "the metrics) instead of refusing with 503.",
    )
    log_dir: Path = Field(default=Path("recordings"), description="Folder of the MCAP files.")
    rotate_bytes: int = Field(default=256 * 2**20, gt=0, description="Rotate files at this size.")
    rotate_age_s: float = Field(default=3600.0, gt=0, description="Rotate files at this age, s.")
    access_log: bool = Field(
        default=False,
        description="Log every request line (uvicorn's access log; plotgate serve only). Off "
        "by default: every exchange is recorded with its request id, and the log line costs "
        "about 16% of a gate test's throughput (measured to a file, 10 clients).",
    )
    git_commit: str | None = Field(default=None, description="Build's commit, if not in git.")
    max_body_bytes: int = Field(
        default=64 * 2**20, gt=0, description="Largest request body, bytes (413 above)."
    )
    body_timeout_s: float = Field(
        default=30.0,
        gt=0,
        description="Deadline for receiving a request's whole body, s "
        "(408 after it, and the connection closed).",
    )
    header_timeout_s: float = Field(
        default=10.0,
        gt=0,
        description="Deadline for a request's headers, from a "
        "connection's start or its previous response, s (the connection is closed after "
        "it; plotgate serve only).",
    )
    probe_interval_s: float = Field(
        default=1.0,
        gt=0,
        le=60,
        description="How often the recorder checks its folder "
        "(re-created when missing; readiness comes back by itself), s; also the "
        "Retry-After of a 503.",
    )
    limits: dict[str, dict[str, int]] = Field(
        default_factory=dict,
        validate_default=True,
        description="Per-operation caps below the schema's bounds, JSON: {operation: "
        '{size: max}}, e.g. {"initiation.evaluate": {"runs": 1000}}, laid over the default '
        f"caps that keep the largest request under {MEMORY_BUDGET_MIB} MiB and "
        f"{TIME_BUDGET_S:g} s on one core (an operator's cap lowers or raises a default, and "
        "a cluster never widens it); the sizes each operation offers, and the caps in force, "
        "are in the OpenAPI schema (x-plotgate-limits).",
    )
    dask_scheduler: str | None = Field(
        default=None,
        description="A Dask scheduler (tcp://host:8786) for initiation.evaluate's Monte Carlo "
        "chunks, whose default work cap then grows with the worker threads it reports, up "
        "to a ceiling; unset: in-process. Unreachable: 503 with Retry-After.",
    )
    dask_timeout_s: float = Field(
        default=300.0,
        gt=0,
        description="Longest wait for one request on the Dask cluster, connecting included, "
        "s (504 cluster-timeout after it; a scheduler that does not answer in time, or "
        "answers nonsense, is 503 cluster-unavailable, within 5 s when this is longer).",
    )
    graceful_shutdown_s: int = Field(
        default=20,
        ge=2,
        le=3600,
        description="On SIGTERM, how long requests in flight may finish, s; a second before "
        "the end, those still computing are answered 503 and recorded, then the recordings "
        "are closed. plotgate serve gives it to uvicorn; under the bare uvicorn command pass "
        "--timeout-graceful-shutdown the same. At least 2 s, so that last second exists; "
        "20 s leaves a 30 s termination grace period (Kubernetes' default) room to close the "
        "recordings.",
    )
    foxglove_port: int | None = Field(
        default=None,
        ge=0,
        le=65535,
        description="Publish every answered exchange's scene live on Foxglove's WebSocket "
        "protocol on this port (plotgate serve --foxglove-port; needs plotgate[view]); unset: "
        "off. 0 picks a free port (logged).",
    )
    foxglove_host: str = Field(
        default="127.0.0.1",
        description="Address the live view binds; it asks for the same keys as the API "
        "(a ?key= in the WebSocket URL, or the API's headers).",
    )
    live_max_clients: int = Field(
        default=64,
        ge=1,
        le=4096,
        description="Live view clients connected at once; one more is refused with 503.",
    )
    api_key: SecretStr | None = Field(
        default=None,
        description="When set, requests need this X-API-Key header (and the live view this key).",
    )
    bearer_token: SecretStr | None = Field(
        default=None,
        description="When set, requests need Authorization: Bearer <token> (and the live "
        "view this token).",
    )
    allow_unauthenticated: bool = Field(
        default=False,
        description="Let the API or the live view listen on an address other than "
        "loopback with no key set (a warning is logged); refused otherwise.",
    )

    @field_validator("limits")
    @classmethod
    def _over_defaults(cls, limits: dict[str, dict[str, int]]) -> dict[str, dict[str, int]]:
        """The caps in force: the operations' defaults, then the operator's over them
        (:func:`plotgate.service.schemas.work_caps`), so every reader of the settings (the
        routes, the OpenAPI schema, the recording's metadata, in-process replay and call)
        sees one table."""
        return work_caps(limits)


@lru_cache
def get_settings() -> Settings:
    """The process's settings, read once."""
    return Settings()
