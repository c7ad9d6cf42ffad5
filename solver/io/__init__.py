"""Files: scene schema and validation (``schema``), scene files, --set and multi-document rules
(``scenes``), HDF5 packing and results files (``hdf5`` writes, ``results`` reads), and the unit
store with its content keys and shared cache (``units``).
"""
