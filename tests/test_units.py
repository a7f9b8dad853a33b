"""Each physical constant is defined once, in vsmp_imu.units, and every room uses that one."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np

from vsmp_imu import units
from vsmp_imu.filtering.plausibility import A_CAP
from vsmp_imu.grounding.align import UNIT_SCALE
from vsmp_imu.imu.channels import GRAVITY_WORLD
from vsmp_imu.imu.sensor import ACC_NOISE_DENSITY

SRC = Path(units.__file__).parent


def _typed_constants(tree: ast.AST) -> list[tuple[int, str]]:
    """Gravity-like numbers (9.7..9.9) and degree/radian factors (180 / pi, pi / 180) in code."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, float) and 9.7 < node.value < 9.9:
            found.append((node.lineno, repr(node.value)))
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
            sides = (node.left, node.right)
            has_pi = any(isinstance(n, ast.Attribute) and n.attr == "pi" for n in sides)
            has_180 = any(isinstance(n, ast.Constant) and n.value == 180 for n in sides)
            if has_pi and has_180:
                found.append((node.lineno, "180 and pi"))
    return found


def test_the_constants_and_their_exact_values():
    assert units.STANDARD_GRAVITY_M_S2 == 9.80665  # exact by definition
    assert math.pi == units.RAD_PER_DEG * 180.0
    assert np.rad2deg(1.0) == units.DEG_PER_RAD


def test_every_room_uses_the_one_gravity():
    g = units.STANDARD_GRAVITY_M_S2
    assert np.array_equal(GRAVITY_WORLD, [0.0, -g, 0.0])
    assert 6 * g == A_CAP
    assert UNIT_SCALE["g"] == 1.0 / g and UNIT_SCALE["deg/s"] == units.DEG_PER_RAD
    assert 300e-6 * g == ACC_NOISE_DENSITY


def test_no_module_types_a_physical_constant_of_its_own():
    found = [f"{path.relative_to(SRC)}:{line}: {what}"
             for path in sorted(SRC.rglob("*.py")) if path.name != "units.py"
             for line, what in _typed_constants(ast.parse(path.read_text()))]
    assert not found, "physical constants typed outside vsmp_imu.units: " + "; ".join(found)


def test_the_scan_finds_a_typed_constant():
    code = "G = 9.81\nA = 6 * G\nK = 180.0 / np.pi\nS = 'reads +9.81 m/s^2'\n"
    assert _typed_constants(ast.parse(code)) == [(1, "9.81"), (3, "180 and pi")]
