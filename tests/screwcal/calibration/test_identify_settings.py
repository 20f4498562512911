"""identify()'s options travel as one frozen, checked IdentifySettings (was an untyped dict
unpacked as **common through three wrappers)."""

import dataclasses

import pytest

from screwcal.calibration.identify_settings import (
    PRIOR_NOISE,
    IdentifySettings,
    NoiseModel,
    resolved_residual,
)
from screwcal.errors import IdentificationError, InputError


def test_settings_are_frozen_and_changed_by_replace():
    settings = IdentifySettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.compliance = "j23"  # type: ignore[misc]  # the point: assignment refused
    bent = dataclasses.replace(settings, compliance="j23")
    assert (settings.compliance, bent.compliance) == ("none", "j23")


def test_an_unknown_weighting_is_refused_when_the_settings_are_made():
    with pytest.raises(IdentificationError, match=r"'statistical' or 'eq2\.4', not 'eq2\.5'"):
        IdentifySettings(weighting="eq2.5")
    assert issubclass(IdentificationError, InputError)


def test_pose_residuals_need_orientations():
    assert resolved_residual(IdentifySettings(), full_pose=True) == "pose"
    assert resolved_residual(IdentifySettings(), full_pose=False) == "position"
    with pytest.raises(IdentificationError, match="positions only"):
        resolved_residual(IdentifySettings(residual="pose"), full_pose=False)


def test_noise_levels_filled_from_the_instrument():
    assert NoiseModel().filled() == PRIOR_NOISE
    assert NoiseModel(position_mm=0.02).filled() == (0.02, *PRIOR_NOISE[1:])
    assert IdentifySettings(noise=NoiseModel(position_mm=0.02)).stated_position_mm() == 0.02
