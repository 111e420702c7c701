import os
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "post"))


@pytest.fixture(scope="session")
def fascia_bin():
    """The fascia program: $FASCIA_BIN (set by CTest) or build/bin/fascia."""
    candidate = os.environ.get("FASCIA_BIN") or str(ROOT / "build" / "bin" / "fascia")
    if not Path(candidate).exists():
        pytest.skip(f"fascia program not found at {candidate} (set FASCIA_BIN)")
    return candidate


@pytest.fixture(scope="session")
def root():
    return ROOT
