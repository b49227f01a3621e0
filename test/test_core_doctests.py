"""The worked examples in the core's docstrings run and print what they say (the papers' reproducible numbers)."""
import doctest
import importlib

import pytest

#: Core modules whose docstrings hold examples.
MODULES = ('core.machine', 'core.naive', 'core.forward', 'core.inverse', 'core.compliance', 'core.mobility',
           'core.sweep', 'inputs.units', 'inputs.files', 'errors', 'inputs.stacked', 'robot.markers', 'core.messages',
           'robot.grid')


@pytest.mark.parametrize('name', MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(f'gpr_kinematics.{name}')
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f'{name} has no examples'
    assert result.failed == 0
