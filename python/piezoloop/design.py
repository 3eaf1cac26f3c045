"""piezoloop.design: the design tools of `piezoloop design`, returning the
JSON the command line prints as dicts.

A model is a dict in the model-file format of configs/models (num/den,
zeros/poles/gain or series; docs/models.md) or the path of such a file.
"""
from __future__ import annotations

import json
import os
from typing import Callable, Optional, Sequence, Union

from . import _piezoloop
from ._args import whole

Model = Union[dict, str, os.PathLike]


def _model_args(model: Model):
    if isinstance(model, dict):
        return json.dumps(model), ""
    if isinstance(model, (str, os.PathLike)):
        return "", os.fspath(model)
    raise ValueError("model: a model-file dict or the path of a model file (JSON)")


def c2d(model: Model, rate_hz: float, method: str = "tustin", format: str = "float", *,
        prewarp_hz: Optional[float] = None, scaling: str = "l1", in_full_scale: float = 1.0,
        out_full_scale: float = 1.0, headroom: float = 1.0, check: bool = True) -> dict:
    """Discretise `model` at rate_hz (Hz) and split it into biquad sections
    scaled for the core's sample type, as `piezoloop design c2d`.

    method: "tustin" (optionally pre-warped at prewarp_hz), "zoh" or
    "matched". format: "float" or "q31" (the CLI's default is q31).
    scaling: "l1", "linf" or "none"; in/out_full_scale: the physical values
    at Q31 full scale; headroom in (0, 1]. check=False skips the
    realisation check (--no-check).

    Returns the CLI's JSON: command, model_file (None for a dict), rate_hz,
    method, continuous, discrete, format, sections (b0, b1, b2, a1, a2),
    scaling, realisation, warnings; and "fit" (the realisation is fit: what
    --strict tests). Bad input raises ValueError naming the field.
    """
    for name, value, allowed in (("method", method, ("tustin", "zoh", "matched")),
                                 ("format", format, ("float", "q31")),
                                 ("scaling", scaling, ("l1", "linf", "none"))):
        if value not in allowed:
            raise ValueError(f"{name}: {value!r} is not one of {', '.join(allowed)}")
    text, path = _model_args(model)
    out = _piezoloop.c2d(text, path, float(rate_hz), method, prewarp_hz, format, scaling, float(in_full_scale),
                         float(out_full_scale), float(headroom), bool(check))
    if not path:
        out["model_file"] = None
    return out


def analyze_loop(plant: Model, controller: Model, *, we: Optional[Model] = None, wy: Optional[Model] = None,
                 hm: Optional[Model] = None, rate_hz: Optional[float] = None, c2d_method: str = "tustin",
                 plant_c2d_method: Optional[str] = None, prewarp_hz: float = 0.0,
                 phase_lag_hz: Sequence[float] = (), family_rel: float = 0.05, family: bool = True) -> dict:
    """The loop of `plant` and `controller` analysed as `piezoloop analyze
    loop`: stability, closed-loop poles, H-inf norms of S, T, KS, GS (and
    We S, Wy T with the weights we, wy), robust stability against the
    multiplicative uncertainty hm (with the coefficient family of
    +-family_rel on the plant's denominator, unless family=False),
    bandwidth_hz, gain and phase margins, phase lags at phase_lag_hz.

    rate_hz: discretise continuous models at this rate (c2d_method, for the
    plant plant_c2d_method if given; Tustin pre-warped at prewarp_hz).
    Returns the CLI's JSON as a dict; ValueError names a bad field.
    """
    for name, value in (("c2d_method", c2d_method), ("plant_c2d_method", plant_c2d_method or "tustin")):
        if value not in ("tustin", "zoh", "matched"):
            raise ValueError(f"{name}: {value!r} is not one of tustin, zoh, matched")
    if rate_hz is not None and not rate_hz > 0:
        raise ValueError("rate_hz: must be > 0")
    if prewarp_hz < 0:
        raise ValueError("prewarp_hz: must be >= 0")
    opt = lambda m: None if m is None else _model_args(m)
    return _piezoloop.analyze_loop(_model_args(plant), _model_args(controller), opt(we), opt(wy), opt(hm),
                                   float(rate_hz or 0.0), c2d_method, plant_c2d_method or "", float(prewarp_hz),
                                   [float(f) for f in phase_lag_hz], float(family_rel), bool(family))


def mixsyn(plant: Model, w1: Model, w2: Optional[Model] = None, w3: Optional[Model] = None, *,
           gamma_tol: float = 1e-6, gamma_max: float = 0.0, backoff: float = 1e-3) -> dict:
    """Mixed-sensitivity H-inf synthesis, as `piezoloop design mixsyn`:
    min ||[W1 S; W2 K S; W3 T]||inf for the plant (continuous models, s in
    rad/s). Returns its JSON: gamma, stable, hinf_W1S, hinf_W2KS, hinf_W3T,
    order, synthesis (the gamma iteration), controller (zpk, e -> u; a
    model dict usable as `controller` of analyze_loop) and controller_ss.
    ValueError for bad input (naming the weight or option); an unsolvable
    problem raises RuntimeError naming the condition."""
    opt = lambda m: None if m is None else _model_args(m)
    return _piezoloop.mixsyn(_model_args(plant), _model_args(w1), opt(w2), opt(w3), float(gamma_tol),
                             float(gamma_max), float(backoff))


def hinf(plant: Model, *, gamma_tol: float = 1e-6, gamma_max: float = 0.0, backoff: float = 1e-3) -> dict:
    """H-inf output-feedback synthesis for a generalised plant, as `piezoloop
    design hinf --plant P.json`: plant is a dict or file in the plant format
    of docs/synthesis.md (A, B, C, D and the partition sizes). Returns its
    JSON: gamma, stable, order, synthesis (the gamma iteration, Riccati
    residuals), controller (state space, y -> u) and, for a SISO
    controller, controller_model (zeros/poles/gain). ValueError names a bad
    field or option; no solution raises RuntimeError naming the condition
    (D12 rank, stabilisability, no gamma in the interval, ...)."""
    if isinstance(plant, dict):
        text, path = json.dumps(plant), ""
    elif isinstance(plant, (str, os.PathLike)):
        text, path = "", os.fspath(plant)
    else:
        raise ValueError("plant: a plant dict or the path of a plant file (JSON)")
    return _piezoloop.hinf(text, path, float(gamma_tol), float(gamma_max), float(backoff))


def musyn(plant: Model, w1: Model, hm: Model, *, w2: Optional[Model] = None, w3: Optional[Model] = None,
          iterations: int = 4, d_order: int = 4, gamma_tol: float = 1e-4, backoff: float = 1e-3,
          on_iteration: Optional[Callable[[int, float, float], None]] = None) -> dict:
    """mu-synthesis by D-K iteration, as `piezoloop design musyn`: plant G
    with input multiplicative uncertainty hm (G (1 + Delta hm), |Delta| <= 1)
    and performance [w1 e; w3 y; w2 u] driven by r. on_iteration(iteration,
    gamma, mu_peak) is called after each K step. Returns its JSON: gamma,
    stable, order, iterations, rs_peak/np_peak/rp_peak of the returned
    controller, controller (zpk, e -> u) and controller_ss. ValueError for
    bad input (naming the model or option), RuntimeError for no solution."""
    opt = lambda m: None if m is None else _model_args(m)
    return _piezoloop.musyn(_model_args(plant), _model_args(w1), _model_args(hm), opt(w2), opt(w3), whole("iterations", iterations),
                            whole("d_order", d_order), float(gamma_tol), float(backoff), on_iteration)


def analyze_mu(plant: Model, controller: Model, hm: Model, w1: Model, *, w3: Optional[Model] = None,
               w2: Optional[Model] = None) -> dict:
    """Robust stability, nominal and robust performance over frequency, as
    `piezoloop analyze mu`: peaks of |hm T| (rs), of the performance channels
    [w1 S; w3 T; w2 K S] (np) and of the mu upper bound for the uncertainty
    and performance blocks (rp), with their frequencies in Hz; each < 1 with
    a nominally stable loop passes (robustly_stable, nominal_performance,
    robust_performance). Models all continuous, or all discrete with one ts."""
    opt = lambda m: None if m is None else _model_args(m)
    return _piezoloop.analyze_mu(_model_args(plant), _model_args(controller), _model_args(hm), _model_args(w1),
                                 opt(w3), opt(w2))


def pi_notch(plant: Model, crossover_hz: float, *, pm_min_deg: float = 45.0, gm_min_db: float = 6.0) -> dict:
    """The classic candidate, as `piezoloop design pi-notch`: PI plus notches
    at the plant's lightly damped resonances above crossover, tuned to
    crossover_hz and lowered until PM >= pm_min_deg and GM >= gm_min_db.
    Returns controller (zpk, e -> u), kp, integral_Hz, target_Hz,
    crossover_Hz, notches, phase_margin_deg, gain_margin_db (None:
    infinite), hinf_S, warnings. ValueError when no crossover meets them."""
    return _piezoloop.pi_notch(_model_args(plant), float(crossover_hz), float(pm_min_deg), float(gm_min_db))


def reduce(model: Model, order: int) -> dict:
    """Balanced truncation of a stable model to `order` states, as `piezoloop
    reduce`: model (zeros/poles/gain), order, original_order, hsv (the Hankel
    singular values, descending) and error_bound (2 x the discarded ones, a
    bound on the H-inf error)."""
    return _piezoloop.reduce(_model_args(model), whole("order", order))


__all__ = ["c2d", "analyze_loop", "mixsyn", "hinf", "musyn", "analyze_mu", "pi_notch", "reduce"]
