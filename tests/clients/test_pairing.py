"""Pairing a request and its response in one step gives what two takes give."""

from hypothesis import given, settings
from hypothesis import strategies as st

from plotgate.clients.pairing import Filters, Pairing, Seen

RECORDS = st.lists(
    st.tuples(
        st.sampled_from(["request", "response"]),
        st.sampled_from(["a", "b", "c"]),  # request id
        st.integers(0, 3),  # time
        st.integers(0, 1),  # digest
        st.sampled_from([None, "a"]),  # replay_of
    ),
    max_size=40,
)


def _seen(at: int, record: tuple[str, str, int, int, str | None]) -> Seen:
    kind, rid, t, digest, replay_of = record
    return Seen(
        kind, "gates.test", rid, t, digest, at, None, replay_of if kind == "request" else None
    )


def _outcome(pairing: Pairing, pairs: list) -> tuple:
    def described(pair):
        return tuple(None if w is None else (w.seen, w.payload) for w in pair[:2]) + pair[2:]

    return (
        [described(p) for p in pairs],
        [described(p) for p in pairing.leftovers()],
        pairing.written_twice,
        pairing.conflict_count,
        pairing.conflicts,
    )


@settings(max_examples=400, deadline=None)
@given(RECORDS, st.sampled_from([None, 2]))
def test_take_pair_is_two_takes(records, since):
    seens = [_seen(at, r) for at, r in enumerate(records)]
    filters = Filters(since=since)
    one, by_one = Pairing(filters), []
    for at, seen in enumerate(seens):
        pair = one.take(None, "f", seen, at)
        if pair is not None:
            by_one.append(pair)
    two, by_two, at = Pairing(filters), [], 0
    while at < len(seens):
        seen = seens[at]
        if at + 1 < len(seens) and seen.kind == "request":
            answer = seens[at + 1]
            if answer.kind == "response" and answer[1:3] == seen[1:3]:
                by_two += two.take_pair("f", seen, answer, (at, at + 1))
                at += 2
                continue
        pair = two.take(None, "f", seen, at)
        if pair is not None:
            by_two.append(pair)
        at += 1
    assert _outcome(one, by_one) == _outcome(two, by_two)
