import os
from typing import Callable, Optional, Sequence, Union

Model = Union[dict, str, os.PathLike]

def c2d(model: Model, rate_hz: float, method: str = "tustin", format: str = "float", *,
        prewarp_hz: Optional[float] = None, scaling: str = "l1", in_full_scale: float = 1.0,
        out_full_scale: float = 1.0, headroom: float = 1.0, check: bool = True) -> dict: ...

def analyze_loop(plant: Model, controller: Model, *, we: Optional[Model] = None, wy: Optional[Model] = None,
                 hm: Optional[Model] = None, rate_hz: Optional[float] = None, c2d_method: str = "tustin",
                 plant_c2d_method: Optional[str] = None, prewarp_hz: float = 0.0,
                 phase_lag_hz: Sequence[float] = (), family_rel: float = 0.05, family: bool = True) -> dict: ...

def mixsyn(plant: Model, w1: Model, w2: Optional[Model] = None, w3: Optional[Model] = None, *,
           gamma_tol: float = 1e-6, gamma_max: float = 0.0, backoff: float = 1e-3) -> dict: ...

def hinf(plant: Model, *, gamma_tol: float = 1e-6, gamma_max: float = 0.0, backoff: float = 1e-3) -> dict: ...

def musyn(plant: Model, w1: Model, hm: Model, *, w2: Optional[Model] = None, w3: Optional[Model] = None,
          iterations: int = 4, d_order: int = 4, gamma_tol: float = 1e-4, backoff: float = 1e-3,
          on_iteration: Optional[Callable[[int, float, float], None]] = None) -> dict: ...

def analyze_mu(plant: Model, controller: Model, hm: Model, w1: Model, *, w3: Optional[Model] = None,
               w2: Optional[Model] = None) -> dict: ...

def pi_notch(plant: Model, crossover_hz: float, *, pm_min_deg: float = 45.0, gm_min_db: float = 6.0) -> dict: ...

def reduce(model: Model, order: int) -> dict: ...
