"""EvalConfig: the constructor normalises, `check` only validates."""

from __future__ import annotations

import copy

import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.evaluate import EvalConfig
from vsmp_imu.har.protocols import DEFAULT_BUDGETS


def test_the_constructor_normalises_the_budgets():
    assert EvalConfig("hapt", protocol="low-resource").budgets == DEFAULT_BUDGETS
    assert EvalConfig("hapt", protocol="low-resource", budgets=(5.0, 1.0)).budgets == (5.0, 1.0)
    assert EvalConfig("hapt", protocol="lopo").budgets == (None,)


def test_check_changes_nothing():
    config = EvalConfig("hapt", protocol="low-resource", budgets=(1.0,), methods=("real",))
    before = copy.deepcopy(config)
    assert config.check() is config
    assert config == before


@pytest.mark.parametrize("kwargs, option", [
    (dict(protocol="lopo", budgets=(5.0,)), "--budgets"),
    (dict(protocol="cross-day"), "--protocol"),
    (dict(alpha=3.0), "--alpha"),
    (dict(seeds=()), "--seeds"),
    (dict(backbones=("svm",)), "--backbones"),
])
def test_check_names_the_option(kwargs, option):
    config = EvalConfig("hapt", **kwargs)
    before = copy.deepcopy(config)
    with pytest.raises(ConfigError) as err:
        config.check()
    assert err.value.field == option
    assert config == before
