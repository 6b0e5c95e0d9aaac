"""Recorded against replayed durations, per operation: the median and the 99th percentile
of each (``numpy.percentile``, linear interpolation), so a replay can say when the service
answers right but slower."""

from collections import defaultdict

import numpy as np

__all__ = ["Durations"]


class Durations:
    """Durations (s) of the exchanges compared, recorded and replayed, by operation."""

    def __init__(self) -> None:
        self._seen: dict[str, list[tuple[float, float]]] = defaultdict(list)

    def add(self, operation: str, recorded: float | None, replayed: float) -> None:
        """One exchange's durations; one without a recorded duration is left out."""
        if recorded is not None:
            self._seen[operation].append((recorded, replayed))

    def percentiles(self) -> dict[str, dict[str, float]]:
        """Per operation: ``recorded_p50``, ``replayed_p50``, ``recorded_p99``,
        ``replayed_p99`` (s) and ``exchanges``."""
        table = {}
        for operation, pairs in sorted(self._seen.items()):
            both = np.asarray(pairs, float)
            p50, p99 = np.percentile(both, [50, 99], axis=0)
            table[operation] = {
                "exchanges": float(len(pairs)),
                "recorded_p50": float(p50[0]),
                "replayed_p50": float(p50[1]),
                "recorded_p99": float(p99[0]),
                "replayed_p99": float(p99[1]),
            }
        return table
