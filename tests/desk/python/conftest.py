"""Shared fixtures of the Python package's tests."""
import gzip
import itertools
import os

import pytest

import ndsid


@pytest.fixture(scope="module")
def head_log(tmp_path_factory):
    """The first 20 000 frames of the bundled clean drives as a plain candump log."""
    path = tmp_path_factory.mktemp("log") / "head.log"
    with gzip.open(os.path.join(ndsid.SOURCE_DIR, "replay", "clean", "drive.log.gz"), "rt") as src, open(path, "w") as dst:
        dst.writelines(itertools.islice(src, 20000))
    return str(path)
