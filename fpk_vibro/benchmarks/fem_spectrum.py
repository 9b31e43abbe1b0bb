"""The FE power spectrum (``fem.spectrum``): seconds, level, reduced basis, estimate and
error, and the peak frequency, on the linear oscillator (against the closed form) and
the paper system for several r (against a finer FE level).

Run ``fpk-vibro bench fem-spectrum`` (``--help`` for options).  The issue's speed case
is the paper system, 200 ω in [0, 3] (three times sqrt(a)), rtol = 1e-3: the "s" column
of its rows, with the estimate made (three levels) included.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ..fem import spectrum
from ..linear import spectrum as exact
from ..model import VibroImpactSystem

LINEAR = VibroImpactSystem(a=1.0, b=0.0, c=0.1, D1=0.01, barriers="none")
#: The paper system's restitution coefficients in the table.
RS = (1.0, 0.98, 0.92, 0.5)
#: The reference level of the paper rows (Q4).
REFERENCE = {"nx": 32, "ny": 64}


def run(system: VibroImpactSystem, of: str, omega: np.ndarray, rtol: float | None,
        reference: bool) -> dict:
    t0 = time.perf_counter()
    sp = spectrum(system, omega, of, rtol=rtol)
    est = sp.error_estimate()
    seconds = time.perf_counter() - t0
    err = float("nan")
    if not system.has_barrier and system.b == 0 and system.D2 == 0:
        ref = exact(system, omega, of).density
        err = float(np.max(np.abs(sp.density - ref)) / np.max(ref))
    elif reference:
        ref = spectrum(system, omega, of, **REFERENCE).density
        err = float(np.max(np.abs(sp.density - ref)) / np.max(ref))
    i = sp.info
    return {"seconds": seconds, "level": f"Q{i['degree']} {i['nx']}x{i['ny']}",
            "ndofs": i["ndofs"], "basis": i["basis_size"], "est": est["relative"], "err": err,
            "peak": sp.peak_frequency(), "var_err": 1.0 - sp.integral() / sp.variance}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fpk-vibro bench fem-spectrum",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--rtol", type=float, default=None, help="accuracy goal (default: "
                    "fem.spectrum's, 1e-3 best effort)")
    ap.add_argument("--n-omega", type=int, default=200, help="frequencies in [0, 3]")
    ap.add_argument("--no-reference", action="store_true",
                    help="skip the finer reference level of the paper rows")
    ap.add_argument("--quick", action="store_true",
                    help="the linear case and r = 0.98, x only, no reference (a smoke test)")
    args = ap.parse_args(argv)
    omega = np.linspace(0.0, 3.0, args.n_omega)
    cases = [("linear c=0.1", LINEAR)] + [(f"paper r={r:g}", VibroImpactSystem.paper(r=r))
                                         for r in RS]
    signals = ("x", "y")
    if args.quick:
        cases, signals = [cases[0], cases[2]], ("x",)
    reference = not (args.quick or args.no_reference)
    print(f"{len(omega)} ω in [0, 3]; err: against the closed form (linear) or Q4 on "
          f"{REFERENCE['nx']} x {REFERENCE['ny']} cells; 1 - ∫S/Var: the ω grid's reach")
    print(f"{'case':>14} {'q':>2} {'level':>12} {'DOFs':>6} {'basis':>5} {'s':>6} "
          f"{'est rel':>8} {'err rel':>8} {'peak ω':>7} {'1-∫S/Var':>8}")
    for name, system in cases:
        for of in signals:
            r = run(system, of, omega, args.rtol, reference)
            print(f"{name:>14} {of:>2} {r['level']:>12} {r['ndofs']:>6} {r['basis']:>5} "
                  f"{r['seconds']:>6.2f} {r['est']:>8.1e} {r['err']:>8.1e} "
                  f"{r['peak']:>7.4f} {r['var_err']:>8.1e}", flush=True)
    return 0


if __name__ == "__main__":          # pragma: no cover
    raise SystemExit(main())
