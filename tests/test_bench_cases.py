"""scripts/bench_cases.py's coupling share after the first write interval, from the plugin's
running means (hand calculations on the reports of a real run-case log)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "bench_cases.py"


@pytest.fixture(scope="module")
def bench_cases():
    spec = importlib.util.spec_from_file_location("bench_cases", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_exchange_after_the_first_write_is_the_mean_of_the_later_requests(bench_cases):
    log = ("Time = 1.912109375\n"
           "stepServer: 22 requests, mean 9460.2 us per exchange\n"
           "Courant Number mean: 0.1 max: 9\n"
           "stepServer: 44 requests, mean 6720.3 us per exchange\n"
           "stepServer: 66 requests, mean 5687.1 us per exchange\n")
    # (66 x 5687.1 - 22 x 9460.2) / 44 us, by hand: (375348.6 - 208124.4) / 44 = 3800.55 us
    assert bench_cases.exchange_after_first_write(log) == pytest.approx(3800.55e-6, rel=1e-9)
    # one report has no later requests; none, no figure
    assert bench_cases.exchange_after_first_write(log.splitlines()[1]) is None
    assert bench_cases.exchange_after_first_write("") is None
