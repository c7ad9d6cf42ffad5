"""Files: scene schema and validation (``schema``), scene files, --set and multi-document rules
(``scenes``), packing and results files in HDF5 (``hdf5`` writes and reads packings, ``results``
reads results), the packing files of LAMMPS, LIGGGHTS and YADE (``dem_formats``), the content
keys of units (``unit_keys``), the unit store with its shared cache and window checkpoints
(``unit_store``), files written whole or not at all (``atomic``), and the exports for OVITO and
ParaView (``export``) with their pictures drawn by VTK (``render``, ``rotsound render``).
"""
