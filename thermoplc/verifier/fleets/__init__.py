"""Many (block, data, model) pairs verified at once: in processes of this machine or as tasks on a Dask cluster."""
