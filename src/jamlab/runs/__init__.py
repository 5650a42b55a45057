"""Ensembles of samples: seeds, storage, resume, local and Dask execution."""
