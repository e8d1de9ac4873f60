"""hlcmp_drake.io.demos: reading a demonstration CSV (a byte-order mark, fuzzed bytes)."""

import random

import numpy as np
import pytest
from conftest import DEMO_CSV, mutations

from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.errors import InputError


def test_a_byte_order_mark_is_invisible_to_the_reader(tmp_path):
    plain, bom = tmp_path / "plain.csv", tmp_path / "bom.csv"
    plain.write_text(DEMO_CSV)
    bom.write_bytes(b"\xef\xbb\xbf" + DEMO_CSV.encode())
    for got, expected in zip(read_demonstration(bom), read_demonstration(plain)):
        np.testing.assert_array_equal(got, expected)
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"\xef\xbb\xbfx,y\n1,2\n")  # a real header problem is still named plainly
    with pytest.raises(InputError, match=r":1: the first column must be 't' .*, found 'x';"):
        read_demonstration(bad)


def test_fuzzed_demonstrations_never_crash(tmp_path):
    rng = random.Random(1234)
    good = "t,x,y,z\n" + "".join(
        f"{k * 0.1:.1f},{0.5 + k * 0.01:.3f},0.0,{0.4 - k * 0.005:.4f}\n" for k in range(15)
    )
    path = tmp_path / "demo.csv"
    outcomes = {"ok": 0, "error": 0}
    for text in mutations(good, rng, 300):
        data = text.encode()
        if rng.random() < 0.1:  # now and then a byte that is not UTF-8 at all
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + b"\xff" + data[cut:]
        path.write_bytes(data)
        try:
            t, positions, axes = read_demonstration(path)
            assert np.all(np.diff(t) > 0) and np.all(np.isfinite(positions)) and len(t) >= 10
            outcomes["ok"] += 1
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0
