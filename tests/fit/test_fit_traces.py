"""Reading traces: 0/1 text, CSV columns, received sequence numbers (gaps, duplicates, reordering, wrap-around)."""

from __future__ import annotations

import numpy as np
import pytest

from kfio.errors import InvalidInput
from kfio.fit import arrivals_from_csv, arrivals_from_sequence, arrivals_from_text, as_trace, fit, parse_trace_text


def test_text_lines_comments_and_blank_lines() -> None:
    a = arrivals_from_text("# radio log\n1\n0\n\n1\r\n1\n", label="log.txt")
    assert a.tolist() == [1, 0, 1, 1]


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        ("1\n0\nx\n", "log.txt line 3", "found 'x'"),
        ("1\n0.5\n", "log.txt line 2", "found '.'"),
        ("", "log.txt", "empty"),
        ("# nothing\n\n", "log.txt", "empty"),
    ],
)
def test_text_refusals_name_the_line(text: str, field: str, words: str) -> None:
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_text(text, label="log.txt")
    assert exc.value.field == field and words in exc.value.rule


def test_string_and_list_refusals_name_the_field() -> None:
    with pytest.raises(InvalidInput) as exc:
        as_trace("0110a1")
    assert exc.value.field == "/arrivals" and "position 5" in exc.value.rule
    with pytest.raises(InvalidInput) as exc:
        as_trace([1, 0, 2])
    assert exc.value.field == "/arrivals/2"
    with pytest.raises(InvalidInput) as exc:
        as_trace([1, True])
    assert exc.value.field == "/arrivals/1"
    with pytest.raises(InvalidInput) as exc:
        as_trace(12)
    assert exc.value.field == "/arrivals"


def test_csv_columns_by_name() -> None:
    text = "t,gps,imu\n0,1,1\n1,0,1\n2,1,0\n"
    cols = arrivals_from_csv(text, ["imu", "gps"])
    assert cols["gps"].tolist() == [1, 0, 1] and cols["imu"].tolist() == [1, 1, 0]
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_csv(text, ["radar"])
    assert exc.value.field == "--column" and "'radar'" in exc.value.rule
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_csv("gps\n1\nyes\n", ["gps"], label="log.csv")
    assert exc.value.field == "log.csv line 3"


def test_sequence_gaps_are_losses() -> None:
    t = arrivals_from_sequence("10\n11\n14\n15\n")
    assert t.arrivals.tolist() == [1, 1, 0, 0, 1, 1]
    assert t.sequence is not None and t.sequence.lost == 2


def test_sequence_duplicates_and_reordering_are_handled_and_reported() -> None:
    # 3 arrives after 4 (late, fills its gap), 4 is received twice, 6 is never received
    t = arrivals_from_sequence([1, 2, 4, 3, 4, 5, 7])
    assert t.arrivals.tolist() == [1, 1, 1, 1, 1, 0, 1]
    s = t.sequence
    assert s is not None and (s.duplicates, s.reordered, s.lost, s.received) == (1, 1, 1, 7)
    assert any("duplicate" in n for n in t.notes) and any("out of order" in n for n in t.notes)


def test_sequence_wraps_around_the_modulus() -> None:
    t = arrivals_from_sequence([65533, 65534, 0, 1, 3], modulus=65536)
    assert t.arrivals.tolist() == [1, 1, 0, 1, 1, 0, 1]  # 65535 and 2 lost
    assert t.sequence is not None and t.sequence.wraps == 1
    # a small modulus: the counter passes 7 -> 0 three times; 3 is lost once
    t = arrivals_from_sequence([6, 7, 0, 1, 2, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0], modulus=8)
    assert len(t) == 19 and t.sequence is not None and t.sequence.wraps == 3 and t.sequence.lost == 1


def test_late_packet_across_the_wrap() -> None:
    t = arrivals_from_sequence([65534, 0, 65535, 1], modulus=65536)
    assert t.arrivals.tolist() == [1, 1, 1, 1]
    assert t.sequence is not None and t.sequence.reordered == 1


def test_sequence_going_back_beyond_the_window_is_refused() -> None:
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_sequence("100\n101\n300\n120\n", window=64, label="seq.log")
    assert exc.value.field == "seq.log line 4"
    assert "180 packets" in exc.value.rule and "window of 64" in exc.value.rule
    # within the window it is a late packet
    t = arrivals_from_sequence("100\n101\n300\n120\n", window=200)
    assert t.sequence is not None and t.sequence.reordered == 1


def test_sequence_refusals() -> None:
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_sequence("1\n2\nthree\n", label="seq.log")
    assert exc.value.field == "seq.log line 3"
    with pytest.raises(InvalidInput) as exc:
        arrivals_from_sequence("70000\n", label="seq.log")
    assert exc.value.field == "seq.log line 1" and "--modulus" in exc.value.rule
    t = arrivals_from_sequence("70000\n70002\n", modulus=None)
    assert t.arrivals.tolist() == [1, 0, 1]
    with pytest.raises(InvalidInput):
        arrivals_from_sequence("", label="seq.log")


def test_sequence_trace_fits_like_its_arrivals() -> None:
    rng = np.random.default_rng(8)
    a = (rng.random(3000) < 0.8).astype(np.uint8)
    a[0] = a[-1] = 1
    seq = "\n".join(str(i % 65536) for i in np.flatnonzero(a) + 65000)
    t = parse_trace_text(seq, sequence=True)["trace"]
    assert t.arrivals.tolist() == a.tolist()
    assert fit(t).parameters == fit(a).parameters
    assert fit(t).to_dict()["sequence"]["wraps"] == 1


@pytest.mark.parametrize(
    ("arrivals", "words"),
    [
        ("1111", "only arrivals"),
        ("000", "only losses"),
    ],
)
def test_one_symbol_only_is_refused(arrivals: str, words: str) -> None:
    with pytest.raises(InvalidInput) as exc:
        fit(arrivals)
    assert exc.value.field == "/arrivals" and words in exc.value.rule


def test_too_short_for_the_model_says_how_many_packets() -> None:
    with pytest.raises(InvalidInput) as exc:
        fit("0110", model="markov", order=3)
    assert "at least 11 packets" in exc.value.rule
    with pytest.raises(InvalidInput) as exc:
        fit("10", model="gilbert_elliott")
    assert "at least 3 packets" in exc.value.rule


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"level": 1}, "/level"),
        ({"level": "0"}, "/level"),
        ({"level": "abc"}, "/level"),
        ({"model": "poisson"}, "/model"),
        ({"model": "markov"}, "/order"),
        ({"model": "markov", "order": 1}, "/order"),
        ({"model": "bernoulli", "order": 2}, "/order"),
        ({"max_order": 9}, "/max_order"),
    ],
)
def test_bad_options_name_their_field(kwargs: dict, field: str) -> None:
    with pytest.raises(InvalidInput) as exc:
        fit("0110111011", **kwargs)
    assert exc.value.field == field
