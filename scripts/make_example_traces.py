"""Write the example packet traces of examples/traces/ (seeded: the same files on every run).

    python scripts/make_example_traces.py

* ``bursty.txt``: 10 000 packets of a Gilbert-Elliott channel, failure rate 0.05, recovery rate 0.3
  (one 0/1 per line, 1 = arrived);
* ``iid_060.txt``: 5 000 independent packets arriving with probability 0.6;
* ``near_037.txt``: 1 000 independent packets arriving with probability 0.37, close to the
  critical arrival probability 9/25 of ``examples/seed004_scalar.json``;
* ``radio_seq.log``: received 16-bit sequence numbers of a bursty link, starting near the wrap,
  with a few duplicates and late packets;
* ``two_sensors.csv``: a header row ``t,gps,imu`` and two 0/1 columns (bursty gps, independent imu).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "examples" / "traces"


def chain(table: list[float], n: int, rng: np.random.Generator) -> list[int]:
    """``n`` arrivals of the Markov channel ``table[h] = P(1 | h)`` (order ``log2 len(table)``)."""
    k = len(table).bit_length() - 1
    h, out = (1 << k) - 1, []
    for u in rng.random(n):
        x = int(u < table[h])
        out.append(x)
        h = (2 * h + x) % (1 << k)
    return out


def lines(values: list[int]) -> str:
    return "\n".join(map(str, values)) + "\n"


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261207)
    (OUT / "bursty.txt").write_text(lines(chain([0.3, 0.95], 10_000, rng)))
    (OUT / "iid_060.txt").write_text(lines(chain([0.6], 5_000, rng)))
    (OUT / "near_037.txt").write_text(lines(chain([0.37], 1_000, rng)))
    arrived = chain([0.3, 0.95], 3_000, rng)
    arrived[0] = arrived[-1] = 1
    numbers = [(65_000 + i) % 65_536 for i, a in enumerate(arrived) if a]
    for i in sorted(rng.choice(len(numbers) - 2, size=12, replace=False), reverse=True):
        if i % 2:
            numbers.insert(i + 1, numbers[i])  # a duplicate
        else:
            numbers[i], numbers[i + 1] = numbers[i + 1], numbers[i]  # a late packet
    (OUT / "radio_seq.log").write_text(lines(numbers))
    gps, imu = chain([0.4, 0.9], 2_000, rng), chain([0.8], 2_000, rng)
    rows = "".join(f"{t},{g},{m}\n" for t, (g, m) in enumerate(zip(gps, imu)))
    (OUT / "two_sensors.csv").write_text("t,gps,imu\n" + rows)


if __name__ == "__main__":
    main()
