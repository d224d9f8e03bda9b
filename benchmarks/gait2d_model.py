"""Size and cost of the planar gait plant (colloc.models.gait2d).

Reports, for one fresh process:

- derive: SymPy/Kane derivation time, and the Model construction time;
- residual size: ``count_ops`` of the 18-row residual (tree count, shared nodes counted
  every time they appear) and the number of CasADi SX instructions after the bridge
  (shared nodes once);
- CasADi SX build time of the residual function, and of its Jacobian with respect to
  ``(x', x)``;
- time per evaluation: the CasADi residual, its Jacobian, and the NumPy (lambdify, cse)
  mass matrix + forcing used for simulation.

Usage: python benchmarks/gait2d_model.py [--repeat 200] [--out benchmarks/results/gait2d_model.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path


def per_call(fn, repeat: int) -> float:
    """Median-free mean seconds per call over ``repeat`` calls (after one warm-up call)."""
    fn()
    t0 = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - t0) / repeat


def run(repeat: int) -> dict:
    t0 = time.perf_counter()
    import casadi as ca
    import numpy as np
    import sympy as sm

    from colloc.models.gait2d import derive
    from colloc.models.gait2d_params import load_parameters
    from colloc.numeric.bridge import sympy_to_casadi

    t_import = time.perf_counter() - t0

    t0 = time.perf_counter()
    gait = derive()
    t_derive = time.perf_counter() - t0

    t0 = time.perf_counter()
    model = gait.to_model()
    t_model = time.perf_counter() - t0

    t0 = time.perf_counter()
    count_ops = int(sm.count_ops(model.residual))
    t_count = time.perf_counter() - t0

    t0 = time.perf_counter()
    groups = {
        "xdot": model.state_derivatives,
        "x": model.states,
        "r": model.inputs,
        "p": model.parameters,
    }
    sx = {k: ca.SX.sym(k, len(v)) for k, v in groups.items()}
    leaves = {s: sx[k][i] for k, v in groups.items() for i, s in enumerate(v)}
    out = sympy_to_casadi(list(model.residual), leaves)
    residual_sx = ca.vertcat(*out)
    args = [sx[k] for k in groups]
    f = ca.Function("F", args, [residual_sx], list(groups), ["F"])
    t_build = time.perf_counter() - t0

    t0 = time.perf_counter()
    z = ca.vertcat(sx["xdot"], sx["x"])
    jac = ca.Function("J", args, [ca.jacobian(residual_sx, z)], list(groups), ["J"])
    t_jac_build = time.perf_counter() - t0

    params = load_parameters()
    pv = gait.constant_array(params)
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.5, 0.5, 9)
    q[1] = 0.95
    u = rng.normal(0, 1, 9)
    torques = rng.normal(0, 10, 6)
    xdot = np.concatenate([u, rng.normal(0, 1, 9)])
    x = np.concatenate([q, u])
    r = np.concatenate([torques, [1.2]])
    dyn = gait.dynamics_function()

    return {
        "model": "gait2d (7 segments, 9 dof, 4 contact points)",
        "python": platform.python_version(),
        "sympy": sm.__version__,
        "casadi": ca.__version__,
        "num_states": model.num_states,
        "num_parameters": len(model.parameters),
        "import_s": t_import,
        "derive_s": t_derive,
        "to_model_s": t_model,
        "residual_count_ops": count_ops,
        "count_ops_s": t_count,
        "casadi_sx_build_s": t_build,
        "casadi_sx_instructions": int(f.n_instructions()),
        "casadi_jacobian_build_s": t_jac_build,
        "casadi_jacobian_nnz": int(jac.sparsity_out(0).nnz()),
        "residual_eval_casadi_s": per_call(lambda: f(xdot, x, r, pv), repeat),
        "jacobian_eval_casadi_s": per_call(lambda: jac(xdot, x, r, pv), repeat),
        "mass_forcing_eval_numpy_s": per_call(lambda: dyn(q, u, torques, 1.2, pv), repeat),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument(
        "--out", type=Path, default=Path(__file__).parent / "results" / "gait2d_model.json"
    )
    ns = parser.parse_args()
    result = run(ns.repeat)
    for key, value in result.items():
        print(f"{key:28s} {value:.4g}" if isinstance(value, float) else f"{key:28s} {value}")
    ns.out.parent.mkdir(parents=True, exist_ok=True)
    ns.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"written to {ns.out}")


if __name__ == "__main__":
    main()
