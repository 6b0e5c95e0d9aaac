"""Track initiation from plots in clutter (Mu et al.; Konovalov; the secondary-processing
textbook).

:mod:`.scan` builds a scan of Cartesian or polar plots, :mod:`.config` holds the rules,
:mod:`.state` the versioned state between calls (:mod:`.state_json` reads one back
and checks it), :mod:`.logic` the initiation itself (:mod:`.filter` its track filter,
:mod:`.search` its candidate search, :mod:`.pairs` the track gates on the candidates,
:mod:`.capture` the capture gates, :mod:`.confirmation` the k/m and score rules,
:mod:`.rules` the choice of each stage's function by the settings, :mod:`.assignment`
and :mod:`.sharing` its association and plot-reuse rules),
:mod:`.simulate` the seeded scenario simulator and :mod:`.evaluate` the Monte Carlo
evaluation (targets initiated, false tracks, time to confirmation).
"""

from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.logic import DROP_REASONS, ScanReport, initiate
from plotgate.core.initiation.scan import Scan, cartesian_scan, polar_scan
from plotgate.core.initiation.state import (
    PLOT_STRIDE,
    STATE_VERSION,
    InitiationState,
    Initiators,
    Tracks,
    empty_state,
)
from plotgate.core.initiation.state_json import check_state, state_from_json

__all__ = [
    "DROP_REASONS",
    "PLOT_STRIDE",
    "STATE_VERSION",
    "InitiationConfig",
    "InitiationState",
    "Initiators",
    "Scan",
    "ScanReport",
    "Tracks",
    "cartesian_scan",
    "check_state",
    "empty_state",
    "initiate",
    "polar_scan",
    "state_from_json",
]
