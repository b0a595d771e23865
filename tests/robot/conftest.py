"""The robot tests' shared fixture: the stack's plan, document and assembly (tests/robot/cases.py)."""

from __future__ import annotations

import pytest

from tests.robot.cases import STACK, STACK_PLAN


@pytest.fixture
def stack():
    """(plan, plan document, assembly) of the 3-block stack on its plate."""
    from rap.robot.inputs import load_plan_and_assembly

    return load_plan_and_assembly(STACK_PLAN, STACK)
