"""A ROS 2 bag whose metadata.yaml has a bad or missing key is refused naming the key.

rosbags' own words named neither the file nor the key for a version that is not a number:
"rb: cannot open the ros2-bag file (Invalid bag metadata: '>' not supported between
instances of 'str' and 'int'.)"; SPEC §4 and §9: the error names the file and the field.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import write_uy_bag

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.data", "y=/y.data")


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            "  version: 8\n",
            "  version: eight\n",
            "metadata.yaml: rosbag2_bagfile_information.version is 'eight', not a whole number",
        ),
        ("  version: 8\n", "", "metadata.yaml: the key 'version' is missing"),
        ("  duration:\n", "  span:\n", "metadata.yaml: the key 'duration' is missing"),
    ],
)
def test_bad_metadata_key_is_named(old: str, new: str, expected: str, tmp_path: Path) -> None:
    folder = write_uy_bag(tmp_path / "bag")
    meta = folder / "metadata.yaml"
    text = meta.read_text()
    assert old in text
    meta.write_text(text.replace(old, new, 1))
    with pytest.raises(LogError) as caught:
        load_signals(folder, SPEC, ReadOptions(maps=MAPS))
    message = str(caught.value)
    assert message.startswith(str(folder)), message
    assert expected in message, message
