"""piezoloop.sim against `piezoloop sim`: the same log hash and metrics for
one case of each scenario (short runs), and the signals' shape."""
import json

import numpy as np
import pytest

import piezoloop
from conftest import cli, scenario

# (scenario, case, frequency_hz, amplitude_um, duration_s, sample)
CASES = [
    ("ahmad2020", "dahl_ff_K", 10.0, 12.0, 0.2, None),
    ("janaideh2016", "ff_fb", 100.0, 20.0, 0.02, None),
    ("janaideh2016", "ff_fb", 100.0, 20.0, 0.02, "q31"),
    ("shan2012", "pi_rc", 1000.0, 10.0, 0.01, None),
]


def cli_args(name, case, f_hz, amp_um, dur_s, sample):
    a = ["sim", "--scenario", scenario(name), "--case", case, "--frequency-hz", str(f_hz), "--amplitude-um",
         str(amp_um), "--duration-s", str(dur_s)]
    return a + (["--sample", sample] if sample else [])


@pytest.mark.parametrize("name,case,f_hz,amp_um,dur_s,sample", CASES)
def test_hash_and_metrics_equal_cli(name, case, f_hz, amp_um, dur_s, sample):
    run = piezoloop.sim(scenario(name), case, frequency_hz=f_hz, amplitude_um=amp_um, duration_s=dur_s,
                        sample=sample)
    args = cli_args(name, case, f_hz, amp_um, dur_s, sample)
    assert run.log_hash == cli(*args, "--hash").strip()
    ref = json.loads(cli(*args))
    for k in ("e_max_um", "e_rms_um", "e_max_pct", "hysteresis_pct", "ticks", "sample", "log_hash"):
        assert run.metrics[k] == ref[k], k
    rate_hz = ref["loop_rate_Hz"]
    s = run.signals
    assert len(s["t_s"]) == ref["ticks"]
    np.testing.assert_array_equal(s["e_um"], (s["r_um"].astype(np.float32) - s["y_um"].astype(np.float32)))
    assert s["t_s"][1] == pytest.approx(1.0 / rate_hz)


def test_sine_double_fidelity_equals_cli():
    a = dict(trajectory="sine", frequency_hz=500.0, amplitude_um=5.0, duration_s=0.004, fidelity="double")
    run = piezoloop.sim(scenario("shan2012"), "pi", **a)
    h = cli("sim", "--scenario", scenario("shan2012"), "--case", "pi", "--trajectory", "sine", "--frequency-hz",
            "500", "--amplitude-um", "5", "--duration-s", "0.004", "--fidelity", "double", "--hash").strip()
    assert run.log_hash == h and run.metrics["fidelity"] == "double"


def test_bad_input_is_value_error():
    with pytest.raises(ValueError, match="trajectory"):
        piezoloop.sim(scenario("shan2012"), "pi", trajectory="saw", amplitude_um=1)
    with pytest.raises(ValueError, match="amplitude"):
        piezoloop.sim(scenario("shan2012"), "pi")
    with pytest.raises(ValueError, match="nope"):
        piezoloop.sim(scenario("shan2012"), "nope", amplitude_um=1, frequency_hz=1000, duration_s=0.001)
