"""The batch tests' shared pieces: small generated inputs and one two-worker LocalCluster."""

from __future__ import annotations

import numpy as np
import pytest

import hybridedit as he

from shapes import bumpy_blob

#: the inputs' cage: a fifth of their 642 vertices (a 5% cage of so small a shape is too coarse to
#: keep most poses within the 50% stretch allowed)
CAGE = 0.2

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")


@pytest.fixture(scope="session")
def cage() -> float:
    """The cage size of the batch tests (:data:`CAGE`)."""
    return CAGE


@pytest.fixture(scope="session")
def inputs(tmp_path_factory):
    """A folder of two small meshes (an OBJ and a binary PLY of another shape)."""
    folder = tmp_path_factory.mktemp("batch-inputs")
    he.write_mesh(folder / "blob.obj", bumpy_blob(3))
    long = bumpy_blob(3)
    he.write_mesh(folder / "long.ply", he.Mesh(long.vertices * np.array([1.4, 0.8, 1.0]), long.faces))
    return folder


@pytest.fixture(scope="session")
def client2(_private_cache_dir):
    """A Dask client on a local cluster of two worker processes (the CI's cluster)."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      env={"NUMBA_NUM_THREADS": "1"}) as cluster, Client(cluster) as client:
        yield client


@pytest.fixture(scope="session")
def posed(inputs, client2, tmp_path_factory):
    """Three poses of each input made on the two workers, written as binary PLY (lossless)."""
    out = tmp_path_factory.mktemp("batch-out")
    table = he.batch([inputs], out, poses=3, seed=11, client=client2, cage_size=CAGE, output_format="ply",
                     progress=False)
    return out, table
