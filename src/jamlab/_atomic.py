"""Former name of :mod:`jamlab.files` (output-path guard and atomic writes), kept so that code
written against it keeps working; import from :mod:`jamlab.files`."""

from jamlab.files import (  # noqa: F401
    atomic_write,
    atomic_write_bytes,
    atomic_write_hdf5,
    check_outputs,
    fsync_dir,
)
