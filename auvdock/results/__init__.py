"""Results of a run: the HDF5 store, the in-memory run and its figures."""
