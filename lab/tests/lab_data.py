"""Where the lab's tests find the recorded data sets: ``../shared/data`` beside the repository."""

from pathlib import Path

#: Tests that need a data set skip cleanly without it.
SHARED_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
