"""piezoloop.design.c2d against `piezoloop design c2d`: the same JSON, for a
model file and for the same model given as a dict."""
import json
import os

import pytest

import piezoloop
from conftest import CONFIGS, cli

MODELS = os.path.join(CONFIGS, "models")


@pytest.mark.parametrize("model,rate,method,fmt", [
    ("ahmad2020_K.json", "10000", "tustin", "float"),
    ("shan2012_Q.json", "100000", "zoh", "q31"),
])
def test_c2d_equals_cli(model, rate, method, fmt):
    path = os.path.join(MODELS, model)
    ref = json.loads(cli("design", "c2d", "--model", path, "--rate-hz", rate, "--method", method, "--format", fmt))
    out = piezoloop.design.c2d(path, float(rate), method=method, format=fmt)
    assert out.pop("fit") == ref["realisation"]["fit"]
    assert out == ref
    with open(path) as f:
        as_dict = piezoloop.design.c2d(json.load(f), float(rate), method=method, format=fmt)
    assert as_dict["model_file"] is None
    assert as_dict["sections"] == ref["sections"] and as_dict["discrete"] == ref["discrete"]


def test_c2d_bad_input():
    with pytest.raises(ValueError, match="rate_hz"):
        piezoloop.design.c2d(os.path.join(MODELS, "ahmad2020_K.json"), -1.0)
    with pytest.raises(ValueError, match="method"):
        piezoloop.design.c2d(os.path.join(MODELS, "ahmad2020_K.json"), 1e4, method="euler")
    with pytest.raises(ValueError):
        piezoloop.design.c2d({"num": [1.0]}, 1e4)


def test_analyze_loop_equals_cli():
    m = {k: os.path.join(MODELS, f"ahmad2020_{k}.json") for k in ("G", "K", "He", "Hy", "Hm")}
    ref = json.loads(cli("analyze", "loop", "--plant", m["G"], "--controller", m["K"], "--we", m["He"], "--wy",
                         m["Hy"], "--hm", m["Hm"], "--no-family", "--phase-lag-hz", "10,100"))
    out = piezoloop.design.analyze_loop(m["G"], m["K"], we=m["He"], wy=m["Hy"], hm=m["Hm"], phase_lag_hz=[10, 100],
                                        family=False)  # the 729-plant family: 20 s, checked by cli_analyze
    assert out == ref
    # The same loop discretised, the controller given as a dict.
    ref = json.loads(cli("analyze", "loop", "--plant", m["G"], "--controller", m["K"], "--rate-hz", "10000",
                         "--plant-c2d", "zoh"))
    with open(m["K"]) as f:
        k = json.load(f)
    out = piezoloop.design.analyze_loop(m["G"], k, rate_hz=10000, plant_c2d_method="zoh")
    assert out == ref and out["stable"] is True


def test_mixsyn_equals_cli(tmp_path):
    # Ahmad2020's G with H_e, W2 = 0.01 (a dict) and H_y (eps_y 1e-2), as tests/host/cli/check_design_synth.py.
    w2 = {"zeros": [], "poles": [], "gain": 0.01}
    w2_file = tmp_path / "w2.json"
    w2_file.write_text(json.dumps(w2))
    g, he, hy = (os.path.join(MODELS, f"ahmad2020_{k}.json") for k in ("G", "He", "Hy_eps1e-2"))
    ref = json.loads(cli("design", "mixsyn", "--plant", g, "--w1", he, "--w2", str(w2_file), "--w3", hy))
    out = piezoloop.design.mixsyn(g, he, w2, hy)
    assert out["weights"]["w2"] == "w2"
    ref["weights"]["w2"] = "w2"
    assert out == ref and out["stable"]
    with pytest.raises(ValueError, match="gamma-tol"):
        piezoloop.design.mixsyn(g, he, gamma_tol=1.0)


# The first-order problem of check_design_synth.py (known optimal gamma).
P1 = {"A": [[0]], "B": [[1, 0, 1]], "C": [[1], [0], [1]], "D": [[0, 0, 0], [0, 0, 1], [0, 1, 0]],
      "partition": {"w": 2, "u": 1, "z": 2, "y": 1}}


def test_hinf_equals_cli(tmp_path):
    path = tmp_path / "p1.json"
    path.write_text(json.dumps(P1))
    ref = json.loads(cli("design", "hinf", "--plant", str(path)))
    out = piezoloop.design.hinf(str(path))
    assert out == ref
    # gamma_opt = sqrt(2); the controller is formed at gamma_opt (1 + backoff 1e-3).
    assert 2 ** 0.5 * (1 - 1e-6) <= out["gamma"] <= 2 ** 0.5 * (1 + 2e-3)
    as_dict = piezoloop.design.hinf(P1)
    assert as_dict["gamma"] == ref["gamma"] and as_dict["plant_file"] == "plant"
    d12 = dict(P1, D=[[0, 0, 0], [0, 0, 0], [0, 1, 0]])
    with pytest.raises(RuntimeError, match="D12"):
        piezoloop.design.hinf(d12)
    with pytest.raises(ValueError, match="plant.B"):
        piezoloop.design.hinf(dict(P1, B=[[1, 0]]))


def test_musyn_analyze_mu_reduce_equal_cli(tmp_path):
    # The small problem of tests/host/cli/check_design_musyn.py.
    models = {"g": ([], [-1, -50], 500), "w1": ([-20], [-0.02], 0.5), "hm": ([-10], [-200], 0.5),
              "w3": ([-10], [-1000], 5)}
    path = {}
    for name, (z, p, k) in models.items():
        path[name] = tmp_path / f"{name}.json"
        path[name].write_text(json.dumps({"zeros": z, "poles": p, "gain": k}))
    p = {k: str(v) for k, v in path.items()}
    ref = json.loads(cli("design", "musyn", "--plant", p["g"], "--w1", p["w1"], "--w3", p["w3"], "--hm", p["hm"],
                         "--iterations", "2", "--d-order", "1"))
    seen = []
    out = piezoloop.design.musyn(p["g"], p["w1"], p["hm"], w3=p["w3"], iterations=2, d_order=1,
                                 on_iteration=lambda i, gamma, mu: seen.append((i, gamma, mu)))
    for r in (ref, out):
        r.pop("seconds")
        for it in r["iterations"]:
            it.pop("seconds")
    assert out == ref
    assert [s[0] for s in seen] == [it["iteration"] for it in ref["iterations"]]
    with pytest.raises(ValueError, match="--iterations"):
        piezoloop.design.musyn(p["g"], p["w1"], p["hm"], w3=p["w3"], iterations=0)

    k = tmp_path / "k.json"
    k.write_text(json.dumps(out["controller"]))
    ref = json.loads(cli("analyze", "mu", "--plant", p["g"], "--controller", str(k), "--hm", p["hm"],
                         "--w1", p["w1"], "--w3", p["w3"]))
    mu = piezoloop.design.analyze_mu(p["g"], out["controller"], p["hm"], p["w1"], w3=p["w3"])
    ref.pop("seconds")
    mu.pop("seconds")
    assert mu == ref
    assert mu["rp_peak"] == pytest.approx(out["rp_peak"]["value"], rel=1e-9)

    ref = json.loads(cli("reduce", "--model", str(k), "--order", "2"))
    red = piezoloop.design.reduce(str(k), 2)
    assert red == ref and red["order"] == 2 and len(red["hsv"]) == out["order"]
    with pytest.raises(ValueError, match="order"):
        piezoloop.design.reduce(out["controller"], 99)


def test_pi_notch_equals_cli():
    d = os.path.join(MODELS, "janaideh2016_D.json")
    ref = json.loads(cli("design", "pi-notch", "--plant", d, "--crossover-hz", "300"))
    out = piezoloop.design.pi_notch(d, 300)
    ref.pop("command")
    ref.pop("plant_file")
    assert out == ref and out["crossover_Hz"] < 300
    with pytest.raises(ValueError, match="crossover_hz"):
        piezoloop.design.pi_notch(d, 300, pm_min_deg=179)
