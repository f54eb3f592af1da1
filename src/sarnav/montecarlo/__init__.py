"""sarnav.montecarlo: Monte Carlo campaigns.

- ``kind``: the ``ScenarioKind`` contract (what the engine asks of a kind) and the checks every scenario shares
- ``record``: the ``RunRecord`` contract (what a kind returns per run)
- ``seeding``: one ``SeedSequence`` child per run, chunking
- ``executors``: ``ChunkRunner`` (serial, local processes, dask.distributed)
- ``store``: atomic per-run files, manifest, ``INCOMPLETE`` marker
- ``assemble``: stored runs -> ``results.nc`` (xarray)
- ``campaign``: ``run_campaign(cfg, out, ...)``, resumable

Import from the submodules (``from sarnav.montecarlo.campaign import run_campaign``). Nothing here
imports ``sarnav.scenarios`` (which sits above): the caller hands ``run_campaign`` the kind instance.
"""
