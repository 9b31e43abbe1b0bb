"""Finite elements for the 2-D FPK on the strip with impacts.

Theory: docs/theory.md, §FPK on the strip to §Transients.

Public API
----------
:func:`stationary`      stationary density → :class:`FEMSolution`
:func:`periodic`        periodic density under harmonic forcing → :class:`~fpk_vibro.periodic.PeriodicResponse`
:func:`spectrum`        stationary power spectrum and correlation → :class:`~fpk_vibro.spectrum.Spectrum`
:func:`assemble`        (L, M) on any skfem basis of the strip (for transient solvers)
:func:`assemble_tensor` the same by Kronecker products on a tensor-product mesh
:func:`domain`          the truncated strip and its walls (default ``y_max`` rule)

Modules: ``stationary`` (:func:`stationary`), ``discretisation`` (:func:`build`: mesh,
L and M, once for every solver), ``forms`` (the weak form, docs/theory.md, §Impact
coupling), ``impact`` (B± coupling), ``generator`` (assembly of L, M), ``mesh`` and
``strip_mesh``, ``solve`` (with ``direct`` and ``amg``), ``positivity`` (with
``positive_grid`` and ``limiter``), ``afc``, ``nonnegative``, ``solution``
(:class:`FEMSolution`, with ``marginals``, ``solution_files``, ``under_resolved``),
``estimate`` and ``compare`` (the error estimate and the rtol solve;
``ladder``: its levels, limits and predicted cost), ``transient``
(with ``relaxation``), ``transient_accuracy`` (rtol) and ``transient_estimate`` (the
estimate without rtol), ``first_passage`` (with ``safe_set`` and
``passage_parts``), ``spectrum`` (with ``spectrum_level`` and ``spectrum_krylov``),
``options`` (with ``wall_layers``).  The benchmarks are in
:mod:`fpk_vibro.benchmarks`.

Measured accuracy and speed on the exact case (orders of Q1/Q2/P1/P2 and of the
positive scheme, where Q2's error sits and why, timings): docs/measurements.md,
§Finite elements on the exact case.
"""
from __future__ import annotations

from .discretisation import Discretisation, build
from .first_passage import first_passage
from .generator import assemble, assemble_tensor
from .mesh import Domain, default_y_max, domain, load_mesh, structured_mesh
from .periodic import periodic
from .options import DEFAULT_NX, DEFAULT_RTOL, POSITIVITY, Options  # noqa: F401
from .solution import FEMSolution
from .solve import SOLVERS
from .spectrum import spectrum
from .stationary import stationary
from .transient import relaxation_time, transient

__all__ = ["stationary", "transient", "periodic", "spectrum", "Options", "Discretisation", "build", "FEMSolution",
           "assemble", "assemble_tensor", "domain", "DEFAULT_NX", "POSITIVITY",
           "default_y_max", "structured_mesh", "load_mesh", "Domain", "SOLVERS",
           "relaxation_time", "first_passage"]
