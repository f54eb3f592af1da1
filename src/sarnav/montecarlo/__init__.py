"""sarnav.montecarlo: Monte Carlo campaigns.

- ``record``: the ``RunRecord`` contract (what a kind returns per run)
- ``seeding``: one ``SeedSequence`` child per run, chunking
- ``executors``: ``ChunkRunner`` (serial, local processes, dask.distributed)
- ``store``: atomic per-run files, manifest, ``INCOMPLETE`` marker
- ``assemble``: stored runs -> ``results.nc`` (xarray)
- ``campaign``: ``run_campaign(cfg, out, ...)``, resumable

Import from the submodules (``from sarnav.montecarlo.campaign import run_campaign``); this package
imports nothing itself, so that ``scenarios.base`` can import ``record`` without cycles.
"""
