"""The application wing: scenes, runs, studies, figures and the command line.

Everything here is built on the physics core (the model, the three methods, the
solutions and their files) and nothing in the core imports from here:

- :mod:`fpk_vibro.app.scenes`, :mod:`~fpk_vibro.app.scene_keys`,
  :mod:`~fpk_vibro.app.plan` — a TOML scene, its keys and the checks before a run;
- :mod:`fpk_vibro.app.runner` with :mod:`~fpk_vibro.app.outdir`,
  :mod:`~fpk_vibro.app.resume`, :mod:`~fpk_vibro.app.interrupt`,
  :mod:`~fpk_vibro.app.pool` and :mod:`~fpk_vibro.app.scheduler` — a run of a scene,
  on worker processes or on Dask, and :mod:`~fpk_vibro.app.estimates`, every answer's
  error estimate in it;
- :mod:`fpk_vibro.app.studies`, :mod:`~fpk_vibro.app.study_plots`,
  :mod:`~fpk_vibro.app.plotting` — studies and figures;
- :mod:`fpk_vibro.app.cli` — the ``fpk-vibro`` command (``fpk-vibro bench`` runs the
  timings of :mod:`fpk_vibro.benchmarks`).
"""
