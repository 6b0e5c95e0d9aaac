"""Repair generated request bodies so they satisfy the rules JSON Schema cannot say.

Schemathesis generates bodies from the OpenAPI schema, field by field; the rules over
several fields (matching lengths, one dimension per request, exactly one of two
alternatives, v_min <= v_max, scans in time order, the size of a smoothing window) are
model validators, so almost no generated body of ``solves.*`` passed them and their
valid paths were never fuzzed. :func:`repaired` takes a body that conforms to the JSON
schema and returns one that also passes those rules while keeping the generated values:
lists are cycled or cut to the length they must have, vectors padded with 0 or cut to the
request's dimension, one alternative of two kept. Every value it writes is one the
schema allows, so a repaired body is still positive data; what remains refused is the
mathematics (a geometry with no solution), which answers 422 naming the field. Given the
server's work caps, it also cuts the work sizes to them (fewer runs, samples, curve
points; a mark with its errors about as large along as across the line of sight), so the
expensive operations are fuzzed with valid data that the caps keep cheap.
"""

import copy
import math
from collections.abc import Callable, Mapping
from typing import Any

Body = dict[str, Any]


def _fit(items: list[Any], n: int) -> list[Any]:
    """``items`` cycled or cut to ``n`` entries (items is never empty: minItems >= 1)."""
    return [copy.deepcopy(items[i % len(items)]) for i in range(n)]


def _point(v: list[float] | None, d: int) -> list[float]:
    """A vector cut or padded with zeros to ``d`` coordinates."""
    v = list(v or [])
    return v[:d] + [0.0] * (d - len(v[:d]))


def _times(times: list[float], least: int) -> list[float]:
    """Strictly increasing distinct times, at least ``least`` of them (within +-1e10)."""
    out = sorted(set(times))
    while len(out) < least:
        out.append(out[-1] + 1.0 if out[-1] + 1.0 <= 1e10 else out[0] - 1.0)
        out.sort()
    return out


def _ordered(node: Any) -> None:
    """Swap every v_min > v_max pair in place (gates, priors, settings)."""
    if isinstance(node, dict):
        if isinstance(node.get("v_min"), float | int) and isinstance(
            node.get("v_max"), float | int
        ):
            lo, hi = sorted((node["v_min"], node["v_max"]))
            node["v_min"], node["v_max"] = lo, hi
        for value in node.values():
            _ordered(value)
    elif isinstance(node, list):
        for value in node:
            _ordered(value)


def _either(body: Body, first: str, second: str, default: Any) -> None:
    """Exactly one of two alternatives: ``first`` if given, else ``second`` (the default
    when absent too)."""
    if body.get(first) is not None:
        body[second] = None
    elif body.get(second) is None:
        body[second] = default


def _platform(p: Body, d: int, n: int | None) -> Body:
    """A platform with d-dimensional vectors; per-sample positions fitted to n samples."""
    if p.get("positions") is not None and n is not None:
        return {"positions": _fit([_point(x, d) for x in p["positions"]], n)}
    position = p.get("position") or (p.get("positions") or [[0.0] * d])[0]
    out: Body = {"position": _point(position, d)}
    if p.get("velocity") is not None and n is not None:
        out["velocity"] = _point(p["velocity"], d)
    return out


def _first_vector(*candidates: Any) -> list[float]:
    for c in candidates:
        if isinstance(c, dict):
            c = c.get("position") or (c.get("positions") or [None])[0]
        if isinstance(c, list) and c and isinstance(c[0], float | int):
            return c
    return [0.0, 0.0]


def _platforms(body: Body, d: int, pairs: int, n: int | None) -> None:
    """Transmitter(s) and receivers fitted to the pairs, dimension and samples."""
    body["receivers"] = [_platform(p, d, n) for p in body["receivers"]]
    if body.get("transmitters") is not None:
        body["transmitter"] = None
        body["transmitters"] = _fit([_platform(p, d, n) for p in body["transmitters"]], pairs)
    else:
        # absent: a transmitter off the origin, where generated targets like to sit
        body["transmitter"] = _platform(body.get("transmitter") or {"position": [1000.0]}, d, n)
    _either(body, "sigmas", "sigma", 1.0)
    if body.get("sigmas") is not None:
        body["sigmas"] = _fit(body["sigmas"], pairs)


def _position(body: Body) -> Body:
    d = len(_first_vector(body["problems"][0]["receivers"][0]))
    for p in body["problems"]:
        p["range_sums"] = _fit(p["range_sums"], max(len(p["range_sums"]), d))
        n = len(p["range_sums"])
        p["receivers"] = _fit([_point(x, d) for x in p["receivers"]], n)
        if p.get("transmitters") is not None:
            p["transmitter"] = None
            p["transmitters"] = _fit([_point(x, d) for x in p["transmitters"]], n)
        else:
            p["transmitter"] = _point(p.get("transmitter"), d)
        _either(p, "sigmas", "sigma", 1.0)
        if p.get("sigmas") is not None:
            p["sigmas"] = _fit(p["sigmas"], n)
        if p.get("initial") is not None:
            p["initial"] = _point(p["initial"], d)
    return body


def _trajectory(body: Body) -> Body:
    body["sample_times"] = _times(body["sample_times"], 2)
    d = len(_first_vector(*body["receivers"]))
    body["receivers"] = _fit(body["receivers"], max(len(body["receivers"]), d))
    t, p = len(body["sample_times"]), len(body["receivers"])
    body["range_sums"] = _fit([_fit(row, p) for row in body["range_sums"]], t)
    _platforms(body, d, p, t)
    if body.get("initial") is not None:
        body["initial"] = {k: _point(body["initial"][k], d) for k in ("position", "velocity")}
    return body


def _crlb(body: Body) -> Body:
    d = len(
        _first_vector(
            *(body.get("targets") or []),
            (body.get("track") or {}).get("position"),
            *body["receivers"],
        )
    )
    least = d + 1 if body.get("measurements") == "difference" else d
    body["receivers"] = _fit(body["receivers"], max(len(body["receivers"]), least))
    p = len(body["receivers"])
    if body.get("targets") is not None:
        body["track"] = None
        body["targets"] = [_point(x, d) for x in body["targets"]]
        n = len(body["targets"])
        moving = any(
            q.get("velocity") is not None
            for q in [
                *body["receivers"],
                *(body.get("transmitters") or []),
                body.get("transmitter") or {},
            ]
        )
        if body.get("sample_times") is not None or moving:
            body["sample_times"] = _fit(_times(body.get("sample_times") or [0.0], 1), n)
    else:
        if body.get("track") is None:
            body["track"] = {"position": [0.0] * d, "velocity": [0.0] * d}
        body["track"] = {k: _point(body["track"][k], d) for k in ("position", "velocity")}
        body["sample_times"] = _times(body.get("sample_times") or [0.0], 1)
        n = len(body["sample_times"])
    _platforms(body, d, p, n)
    if body.get("sample_times") is None:  # no times: fixed platforms only
        for q in [*body["receivers"], *(body.get("transmitters") or [])]:
            q.pop("velocity", None)
    return body


def _noise(body: Body) -> Body:
    body["sample_times"] = _times(body["sample_times"], 1)
    t = len(body["sample_times"])
    if t < 2:  # a fit needs degree + 2 samples: smoothing only
        body["range_sums"] = None
    if body.get("range_sums") is None and body.get("positions") is None:
        body["positions"] = [[float(i), 0.0] for i in range(t)]
    if body.get("range_sums") is not None:
        body["degree"] = min(body.get("degree", 2), t - 2)
        width = len(body["range_sums"][0])
        body["range_sums"] = _fit([_fit(row, width) for row in body["range_sums"]], t)
    if body.get("positions") is not None:
        d = len(body["positions"][0])
        body["positions"] = _fit([_point(x, d) for x in body["positions"]], t)
        body["smoothing_degree"] = min(body.get("smoothing_degree", 2), t - 1)
        low = body["smoothing_degree"] + 1
        body["window"] = min(max(body.get("window") or low, low), t)
    else:
        body["window"] = None
    return body


def _study(body: Body) -> Body:
    body["sample_times"] = _times(body["sample_times"], 2)
    t = len(body["sample_times"])
    d = len(body["target"]["position"])
    body["target"] = {k: _point(body["target"][k], d) for k in ("position", "velocity")}
    body["transmitter"] = _platform(body["transmitter"], d, t)
    body["receivers"] = [_platform(p, d, t) for p in body["receivers"]]
    return body


def _probability(body: Body) -> Body:
    _either(body, "prior", "velocity", {"speed": 100.0})
    return body


def _curve(body: Body) -> Body:
    if body["against"] == "speed":
        body["speed"] = body["prior"] = None
        body["values"] = [min(v, 1e6) for v in body["values"]]
    else:
        _either(body, "prior", "speed", 100.0)
        body["values"] = [max(v, 1.0) for v in body["values"]]
        if body.get("prior") is not None:
            body["values"] = body["values"][:100]
    return body


def _pair(body: Body) -> Body:
    if body.get("delta_deg") is None:
        body["beta_max"] = None
    elevations = ("passive_elevations_deg", "active_elevations_deg")
    if any(body.get(k) is None for k in elevations):
        body.update(dict.fromkeys(elevations))
    else:
        for side in ("passive", "active"):
            body[f"{side}_elevations_deg"] = _fit(
                body[f"{side}_elevations_deg"], len(body[f"{side}_bearings_deg"])
            )
    return body


def _picture(body: Body) -> Body:
    if isinstance(body.get("sigma_deg"), list):
        body["sigma_deg"] = _fit(body["sigma_deg"], len(body["passive_deg"]))
    return body


def _initiate(body: Body) -> Body:
    body["state"] = None  # a state is one a previous call answered, never generated
    body["scans"] = sorted(body["scans"], key=lambda s: s["t"])
    return body


def _settings(config: Any) -> None:
    """Initiation settings: gate widening factors >= 1 and non-decreasing."""
    if isinstance(config, dict) and config.get("gate_widening"):
        config["gate_widening"] = sorted(max(g, 1.0) for g in config["gate_widening"])


def _isotropic(mark: Body) -> None:
    """The mark's errors made equal along and across the line of sight (B's axis ratio 1:
    sigma_r = r sigma_az, both within their bounds at any r), keeping r."""
    r = mark["r"]
    sigma = min(max(r * math.radians(mark["sigma_az_deg"]), 1e-3), 1e9)
    mark["sigma_r"] = sigma
    mark["sigma_az_deg"] = min(max(math.degrees(sigma / r), 1e-6), 180.0)
    mark["sigma_r2"] = mark["sigma_az2_deg"] = None


def _within(body: Body, caps: Mapping[str, int]) -> None:
    """Cut the body's work sizes to the server's caps (PLOTGATE_LIMITS), in place."""
    for size, cap in caps.items():
        if size == "runs":  # absent: the default, often over the cap
            body[size] = min(int(body.get(size, cap)), cap)
        elif size in ("values", "sample_times") and body.get(size) is not None:
            body[size] = body[size][:cap]
        elif size in ("scenario.scans", "scenario.clutter") and body.get("scenario"):
            key = size.split(".")[1]
            if key in body["scenario"]:
                body["scenario"][key] = min(body["scenario"][key], cap)
        elif size == "mark.axis_ratio":
            _isotropic(body["mark"])
            if body.get("against") == "range" and body.get("prior") is not None:
                r = body["mark"]["r"]  # each range's own ratio stays near 1 too
                body["values"] = [min(max(v, 0.5 * r), 2.0 * r) for v in body["values"]]


REPAIRS: dict[str, Callable[[Body], Body]] = {
    "/v1/solves/position": _position,
    "/v1/solves/trajectory": _trajectory,
    "/v1/solves/crlb": _crlb,
    "/v1/solves/noise": _noise,
    "/v1/solves/study": _study,
    "/v1/gates/probability": _probability,
    "/v1/gates/probability/curve": _curve,
    "/v1/identification/pair": _pair,
    "/v1/identification/picture": _picture,
    "/v1/initiation/initiate": _initiate,
}
"""Operation path -> the repair of its cross-field rules."""


def repaired(path: str, body: Body, caps: Mapping[str, int] | None = None) -> Body:
    """A copy of a schema-valid ``body`` that also passes the operation's own rules and,
    given the server's ``caps`` on the operation's work sizes, stays within them.

    A body whose shape the repair cannot read is returned as it came: Schemathesis'
    coverage phase labels some bodies positive that break the schema's types.
    """
    fixed = copy.deepcopy(body)
    try:
        _within(fixed, caps or {})
        _ordered(fixed)
        _settings(fixed.get("config"))
        repair = REPAIRS.get(path)
        return fixed if repair is None else repair(fixed)
    except (TypeError, KeyError, IndexError, AttributeError, ZeroDivisionError, ValueError):
        return body
