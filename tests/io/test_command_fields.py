"""A command column the log has but that holds no sample is refused as a command.

Commands are held onto the grid as inputs are, and an empty one was refused by the
alignment as ``input 'cmd' (column 'cmd') has no samples``: the model has no input of that
name, so the user looked for one.
"""

import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, load_signals
from hybridlog.model.loader import parse_model
from tests.estimators.test_cpha_commands import TINY


def test_an_empty_command_column_is_named_as_a_command(tmp_path):
    log = tmp_path / "log.csv"
    log.write_text("t,u,y,cmd\n0,1,0,\n1,1,0.5,\n2,1,1,\n", encoding="utf-8")
    with pytest.raises(LogError) as raised:
        load_signals(log, SignalSpec.of(parse_model(TINY)))
    assert str(raised.value) == f"{log}: command 'cmd' (column 'cmd') has no samples"
