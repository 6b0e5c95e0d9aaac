"""Every numeric field of every operation, driven to its bounds and to IEEE extremes.

Each operation starts from its OpenAPI example (its declaration's ``example_body``,
:data:`plotgate.service.table.ENDPOINTS`)
and the few variants below that reach the other branches of its schema (gate kinds, plot
frames, optional fields). Every number in a base (its defaults included) is replaced, one
at a time, by

- 0, the smallest subnormal 5e-324, the smallest normal 2.2250738585072014e-308, 1e-300,
  1e-160, 1e300 and the largest double, each with both signs;
- each of the schema's own bounds (inclusive or exclusive), the double just inside it and
  the double just outside it (``math.nextafter``);

an integer by 0, -1, 2**63 and each bound, bound - 1 and bound + 1. Lists are mutated in
their first element (a list of numbers: every entry), tuples in every position. Every
answer must be below 500, and every refusal a problem naming fields of the *request*:
the first segment of each field is a field of the request model (never a response field
such as ``probability``).

Runtime is kept bounded (under a minute on two cores) in two ways. Requests run
in-process through :func:`plotgate.service.registry.execute`, as the HTTP route runs them. And
each operation runs under ``PLOTGATE_LIMITS``-style caps (:data:`CAPS`) on its declared
work sizes, so driving a work-size field (Monte Carlo ``runs``, ``scenario.scans``,
``scenario.clutter``) to its bound answers a quick 422 naming it instead of computing
for minutes; the gating probability operations cap ``mark.axis_ratio``, the
eccentricity of the marks' error ellipse that sets the cost of the unconditional
quadrature (0.1 s at the paper's ratio of 2, seconds at 20, minutes at the 10^5 the
sigmas' bounds allow; ``bench/HISTORY.md``). The mark's fields still reach their bounds
in every operation's conditional or area-only variant, which costs milliseconds at any
ratio; a run without the caps is in docs/reliability.md.

A last check holds the bases to the schema: every numeric property of every model a
request can contain is mutated at least once, so a new field cannot escape the test.
"""

import json
import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from pydantic import BaseModel

from plotgate.service.registry import OPERATIONS, execute

Path = tuple[str | int, ...]

SPECIALS = [0.0, 5e-324, 2.2250738585072014e-308, 1e-300, 1e-160, 1e300, 1.7976931348623157e308]
FLOATS = SPECIALS + [-x for x in SPECIALS]
INTS = [0, -1, 2**63]

CAPS: dict[str, dict[str, int]] = {
    "gates.probability": {"mark.axis_ratio": 4},
    "gates.probability_curve": {"mark.axis_ratio": 4},
    "gates.analysis": {"mark.axis_ratio": 4},
    "gates.design": {"mark.axis_ratio": 4},
    "solves.study": {"runs": 50},
    "initiation.simulate": {"scenario.scans": 50},
    "initiation.evaluate": {
        "runs": 10,
        "scenario.scans": 50,
        "scenario.clutter": 100,
        "sweep.values": 3,
    },
    "identification.simulate": {"runs": 1000},
}
"""Caps on declared work sizes, as ``PLOTGATE_LIMITS`` would set them (see the docstring)."""

# --- bases: the example and the variants reaching the rest of each schema ----------------

_POLAR = {
    "frame": "polar",
    "r": 20_000.0,
    "az_deg": 30.0,
    "sigma_r": 100.0,
    "sigma_az_deg": 0.3,
    "sensor": [100.0, -50.0],
}
_CARTESIAN = {
    "frame": "cartesian",
    "x": 1000.0,
    "y": 20_000.0,
    "covariance": [[4e4, 1e3], [1e3, 9e4]],
    "sensor": [0.0, 0.0],
}
_GATES = [
    {"kind": "ring", "tau": 5.0, "v_min": 100.0, "v_max": 500.0},
    {"kind": "expanded", "tau": 5.0, "v_max": 500.0, "p": 0.9},
    {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
    {"kind": "ellipse", "P_G": 0.99},
    {"kind": "rectangular", "k": 3.0},
    {"kind": "sector", "K_R": 3.0, "K_az": 3.0},
    {"kind": "first_association", "tau": 5.0, "v_max": 500.0, "K_R": 3.0, "K_az": 3.0},
]
_REGIONS = [
    {"kind": "ring", "v_min": 100.0, "v_max": 500.0},
    {"kind": "combined", "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
    {"kind": "expanded", "v_max": 500.0, "p": 0.9},
    {"kind": "ellipse", "P_G": 0.99, "offset": [300.0, -200.0]},
    {"kind": "rectangular", "k": 3.0, "offset": [300.0, -200.0]},
    {"kind": "sector", "K_R": 3.0, "K_az": 3.0, "offset": [300.0, -200.0]},
    {"kind": "first_association", "v_max": 500.0, "K_R": 3.0, "K_az": 3.0},
]
_MARK2 = {
    "r": 30_000.0,
    "az_deg": 45.0,
    "sigma_r": 150.0,
    "sigma_az_deg": 0.4,
    "sigma_r2": 120.0,
    "sigma_az2_deg": 0.3,
}
_VELOCITY = {"speed": 300.0, "course_deg": 30.0}
_PRIOR = {"kind": "speed", "v_min": 100.0, "v_max": 500.0}
_TX = [0.0, 0.0]
_RX = [[10_000.0, 0.0], [0.0, 10_000.0], [-8000.0, -6000.0]]

Variant = Callable[[dict[str, Any]], dict[str, Any]]


def _with(**fields: Any) -> Variant:
    """The example with some top-level fields replaced (None where a field is nullable)."""
    return lambda example: {**example, **fields}


def _conditional(op: str) -> list[Variant]:
    """The gating-probability variants: conditional (or area-only), any geometry is cheap."""
    if op == "gates.probability":
        return [_with(gate=g, mark=_MARK2, prior=None, velocity=_VELOCITY) for g in _REGIONS]
    if op == "gates.probability_curve":
        return [
            *(_with(gate=g, mark=_MARK2) for g in _REGIONS),
            _with(against="range", values=[20_000.0, 40_000.0], speed=300.0),
            _with(against="range", values=[50_000.0], prior=_PRIOR),
        ]
    return [_with(gate=g, mark=_MARK2, prior=None) for g in _REGIONS]  # gates.analysis


def _platforms(example: dict[str, Any], times: int) -> dict[str, Any]:
    """Moving and per-sample platforms, several transmitters and sigmas."""
    return {
        **example,
        "transmitter": None,
        "transmitters": [
            {"positions": [[10.0, 20.0]] * times},
            {"position": [0.0, 0.0]},
            {"position": [-20.0, 5.0]},
        ],
        "receivers": [{"position": p, "velocity": [1.0, 2.0]} for p in _RX],
        "sigma": None,
        "sigmas": [0.5, 0.6, 0.7],
    }


def _state(example: dict[str, Any]) -> dict[str, Any]:
    """initiation.initiate continuing the state its example returns."""
    answer = execute(OPERATIONS["initiation.initiate"], json.dumps(example).encode())
    assert answer.status == 200, answer.content
    return {**example, "state": answer.json()["state"], "scans": [{"t": 3.0, "plots": [_POLAR]}]}


_POLAR_CONFIG = {"mode": "polar", "capture_time": 2.0, "K_R": 3.0, "K_az": 3.0}


def _polar_state(example: dict[str, Any]) -> dict[str, Any]:
    """Continuing a polar session's state: a track with its ranges and times, and a plot
    far from it still waiting as an initiator."""
    far = {**_POLAR, "r": _POLAR["r"] + 5000.0}
    return _state(
        {
            **example,
            "config": _POLAR_CONFIG,
            "scans": [
                {"t": 0.0, "plots": [_POLAR]},
                {"t": 1.0, "plots": [_POLAR]},
                {"t": 2.0, "plots": [_POLAR, far]},
            ],
        }
    )


def _tentative_state(example: dict[str, Any]) -> dict[str, Any]:
    """Continuing a state with a tentative track, so the plots it holds are carried."""
    scans = [{"t": 0.0, "plots": [_POLAR]}, {"t": 1.0, "plots": [_POLAR]}]
    return _state({**example, "config": _POLAR_CONFIG, "scans": scans})


VARIANTS: dict[str, list[Variant]] = {
    "gates.test": [_with(gate=g, first=_CARTESIAN, candidates=[_POLAR]) for g in _GATES],
    "gates.pairs": [
        _with(gate=g, pairs=[{"first": _POLAR, "second": _CARTESIAN}]) for g in _GATES
    ],
    "gates.probability": _conditional("gates.probability"),
    "gates.probability_curve": _conditional("gates.probability_curve"),
    "gates.analysis": _conditional("gates.analysis"),
    "gates.design": [
        _with(gate={"kind": "combined", "v_min": 0.0, "v_max": 300.0, "P_G": 0.9}, mark=_MARK2)
    ],
    "solves.position": [
        lambda e: {
            **e,
            "problems": [
                {
                    "range_sums": e["problems"][0]["range_sums"],
                    "transmitters": [_TX] * 3,
                    "receivers": _RX,
                    "sigmas": [0.5, 0.5, 0.5],
                    "initial": [3100.0, 3900.0],
                }
            ],
        }
    ],
    "solves.trajectory": [
        lambda e: {
            **_platforms(e, 4),
            "initial": {"position": [3000.0, 4000.0], "velocity": [50.0, -20.0]},
        }
    ],
    "solves.crlb": [
        _with(
            targets=None,
            track={"position": [3000.0, 4000.0], "velocity": [50.0, -20.0]},
            sample_times=[0.0, 1.0, 2.0],
            measurements="difference",
        ),
        lambda e: {**_platforms(e, 2), "sample_times": [0.0, 1.0]},
    ],
    "solves.study": [
        _with(
            transmitter={"position": [0.0, 0.0], "velocity": [5.0, -3.0]},
            receivers=[
                {"positions": [[10_000.0, 0.0]] * 4},
                {"position": [0.0, 10_000.0], "velocity": [1.0, 2.0]},
                {"position": [-8000.0, -6000.0]},
            ],
            tracks=False,
        ),
    ],
    "initiation.initiate": [
        _with(
            config=_POLAR_CONFIG,
            scans=[{"t": 0.0, "plots": [_POLAR]}, {"t": 1.0, "plots": [_POLAR]}],
        ),
        _state,
        _polar_state,
        _tentative_state,
        *(
            _with(
                config={**_POLAR_CONFIG, "confirmation": "score", **density},
                scans=[{"t": 0.0, "plots": [_POLAR]}, {"t": 1.0, "plots": [_POLAR]}],
            )
            for density in ({"clutter_density": 1e-6}, {"surveillance_area": 2.25e8})
        ),
    ],
    "initiation.evaluate": [
        _with(config={"capture_time": 2.0, "K_R": 3.0, "K_az": 3.0}),
        _with(config={"confirmation": "score", "clutter_density": 1e-6}),
        _with(
            config={"confirmation": "score", "surveillance_area": 2.25e8},
            sweep={"parameter": "gate_P_G", "values": [0.9, 0.99]},
        ),
    ],
    "identification.pair": [
        _with(
            sigma_deg=0.2,
            passive_elevations_deg=[1.0, 1.2, 0.9, 1.1, 1.0, 0.8],
            active_elevations_deg=[1.0, 1.1],
            sigma_elevation_deg=0.1,
        ),
    ],
    "identification.picture": [_with(sigma_deg=[0.2, 0.3])],
}


def _bases(name: str) -> Iterator[dict[str, Any]]:
    example = OPERATIONS[name].endpoint.example
    yield example
    for variant in VARIANTS.get(name, []):
        yield variant(example)


# --- the numeric leaves of a request and their bounds -------------------------------------


Leaf = tuple[Path, str, str, Path, Any]
"""(path in the body, owning model, its field, path below that field, value)."""


def _leaves(model: BaseModel, body: dict[str, Any]) -> Iterator[Leaf]:
    """Every number in a request, with the model field it belongs to.

    ``body`` is the request dumped with its defaults, walked beside the validated model so
    each number knows its model and field (the initiation ``state`` included).
    """

    def walk(node: Any, data: Any, path: Path, owner: tuple[str, str, int]) -> Iterator[Leaf]:
        if isinstance(data, bool) or data is None or isinstance(data, str):
            return
        if isinstance(data, int | float):
            model, field, depth = owner
            yield path, model, field, path[depth:], data
        elif isinstance(node, BaseModel):
            for field in type(node).model_fields:
                yield from walk(
                    getattr(node, field),
                    data[field],
                    (*path, field),
                    (type(node).__name__, field, len(path) + 1),
                )
        elif isinstance(data, list) and data:
            numbers = all(
                x is None or isinstance(x, int | float) and not isinstance(x, bool) for x in data
            )  # a numeric row, gaps (null) allowed
            every = isinstance(node, tuple) or numbers
            for i in range(len(data) if every else 1):
                yield from walk(node[i], data[i], (*path, i), owner)

    yield from walk(model, body, (), (type(model).__name__, "", 0))


def _number_schema(schema: dict[str, Any], rest: Path, value: Any) -> dict[str, Any]:
    """The JSON schema of the number at ``rest`` below a property's schema."""
    for key in ("anyOf", "oneOf"):
        if key in schema:
            want = "array" if rest else ("integer" if isinstance(value, int) else "number")
            branches = [
                b
                for b in schema[key]
                if b.get("type") in ({want, "number"} if want == "integer" else {want})
            ]
            return _number_schema(branches[0], rest, value)
    if not rest:
        return schema
    items = schema.get("prefixItems")
    item = items[rest[0]] if items else schema.get("items", {})
    return _number_schema(item, rest[1:], value)


def _bounds(
    schemas: dict[str, dict[str, Any]], model: str, field: str, rest: Path, value: Any
) -> dict[str, Any]:
    """The schema of a leaf: its type and bounds."""
    return _number_schema(schemas[model]["properties"][field], rest, value)


def _values(schema: dict[str, Any], value: Any) -> list[Any]:
    """The values a number is driven to: IEEE extremes and the schema's own bounds."""
    integer = isinstance(value, int) and schema.get("type") != "number"
    out: list[Any] = list(INTS) if integer else list(FLOATS)
    for key, inward in (
        ("minimum", 1),
        ("exclusiveMinimum", 1),
        ("maximum", -1),
        ("exclusiveMaximum", -1),
    ):
        if key not in schema:
            continue
        bound = schema[key]
        if integer:
            out += [bound - 1, bound, bound + 1]
        else:
            bound = float(bound)
            out += [
                bound,
                math.nextafter(bound, inward * math.inf),
                math.nextafter(bound, -inward * math.inf),
            ]
    return list(dict.fromkeys(out))


def _set(body: Any, path: Path, value: Any) -> Any:
    """A copy of ``body`` with the value at ``path`` replaced."""
    if not path:
        return value
    head, rest = path[0], path[1:]
    if isinstance(body, list):
        return [_set(x, rest, value) if i == head else x for i, x in enumerate(body)]
    return {**body, head: _set(body[head], rest, value)}


def _model_schemas(request: type[BaseModel]) -> dict[str, dict[str, Any]]:
    """Every model a request can contain, by name, with its JSON schema (the request too)."""
    schema = request.model_json_schema()
    return {request.__name__: schema, **schema.get("$defs", {})}


def _numeric(schema: Any) -> bool:
    """A property schema whose value is, or holds, numbers (not through another model)."""
    if isinstance(schema, dict):
        if schema.get("type") in ("number", "integer"):
            return True
        return any(_numeric(schema.get(k)) for k in ("anyOf", "oneOf", "items", "prefixItems"))
    if isinstance(schema, list):
        return any(_numeric(s) for s in schema)
    return False


def _numeric_fields(request: type[BaseModel]) -> set[tuple[str, str]]:
    return {
        (model, field)
        for model, schema in _model_schemas(request).items()
        for field, prop in schema.get("properties", {}).items()
        if _numeric(prop)
    }


# --- the test ------------------------------------------------------------------------------


def _top(field: str) -> str:
    return field.replace("[", ".").split(".")[0]


def _drive(name: str) -> set[tuple[str, str]]:
    """Run every mutation of the operation's bases; returns the (model, field)s mutated."""
    op = OPERATIONS[name]
    schemas = _model_schemas(op.request)
    request_fields = set(op.request.model_fields)
    limits = CAPS.get(name)
    done: set[tuple[str, Path]] = set()
    mutated: set[tuple[str, str]] = set()
    failures = []
    for base in _bases(name):
        model = op.request.model_validate_json(json.dumps(base), strict=True)
        body = model.model_dump(mode="json")
        for path, owner, field, rest, value in _leaves(model, body):
            if (owner, path) in done:
                continue
            done.add((owner, path))
            mutated.add((owner, field))
            for new in _values(_bounds(schemas, owner, field, rest, value), value):
                request = json.dumps(_set(body, path, new)).encode()
                where = f"{'.'.join(map(str, path))} = {new!r}"
                try:  # what escapes execute, the route answers 500
                    outcome = execute(op, request, None, limits)
                except Exception as exc:
                    failures.append(f"{where}: raised {type(exc).__name__}: {exc}"[:400])
                    continue
                if outcome.status >= 500:
                    failures.append(f"{where}: {outcome.status} {outcome.content[:300]!r}")
                elif outcome.status >= 400:
                    problem = outcome.json()
                    fields = [e["field"] for e in problem.get("errors", [])]
                    if (
                        outcome.error is None
                        or problem["status"] != outcome.status
                        or not fields
                        or not {_top(f) for f in fields} <= request_fields
                    ):
                        failures.append(f"{where}: {outcome.status} names {fields}")
    assert not failures, f"{len(failures)} bad answers:\n" + "\n".join(failures[:40])
    return mutated


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_numeric_fields_at_their_bounds(name):
    mutated = _drive(name)
    missing = _numeric_fields(OPERATIONS[name].request) - mutated
    assert not missing, f"numeric fields no base reaches: {sorted(missing)}"
