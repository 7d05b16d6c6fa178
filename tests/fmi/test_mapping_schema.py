"""A mapping file is validated as a scenario is (issue 18): any nesting, every [fmu] value, typos."""

import pytest

from postcapture.core.errors import FMIError
from postcapture.fmi.mapping import Mapping
from tiny_fmu import MAPPING


def test_deep_nesting_is_a_mapping_error_not_a_recursion_error():
    text = MAPPING + "deep = " + "[" * 3000 + "]" * 3000 + "\n"
    with pytest.raises(FMIError, match="invalid mapping|not valid TOML"):
        Mapping.from_text(text, "deep.toml")
    with pytest.raises(FMIError, match=r"\(mapping\)|expected"):
        nested: dict = {}
        node = nested
        for _ in range(3000):
            node["x"] = {}
            node = node["x"]
        Mapping.from_dict({**Mapping.from_text(MAPPING).to_dict(), "state": nested})


@pytest.mark.parametrize(("fmu", "needle"), [
    ('format = 2\n', "format: expected one of 1"),
    ('[fmu]\nguid = "not a guid"\n', "[fmu] guid: expected"),
    ('[fmu]\nstep = -1.0\n', "[fmu] step: expected a number > 0"),
    ('[fmu]\nstep = nan\n', "[fmu] step: expected a finite number"),
    ('[fmu]\nstep = 1e300\n', "[fmu] step: expected a number <= 10000"),
    ('[fmu]\nintegrator = "euler"\n', "[fmu] integrator: expected one of 'sdirk4'"),
    ('[fmu]\nmodel_identifier = "two words"\n', "[fmu] model_identifier: expected"),
    ('[fmu]\nstpe = 0.1\n', "[fmu] stpe: expected a known key (this one is not part of the schema), found 'stpe' "
                            "(did you mean 'step'?)"),
])
def test_every_fmu_value_is_checked(fmu, needle):
    with pytest.raises(FMIError) as info:
        Mapping.from_text(fmu + MAPPING.replace("format = 1\n", ""))
    assert needle in str(info.value), str(info.value)


def test_two_problems_are_both_listed():
    text = MAPPING.replace('kinematics = "quaternion"', 'kinematics = "euler"').replace("[measurement]", "[measurement]\nacel = 1")
    with pytest.raises(FMIError) as info:
        Mapping.from_text(text)
    msg = str(info.value)
    assert "[state] kinematics: expected one of" in msg and "[measurement] acel: expected a known key" in msg


def test_a_good_mapping_round_trips_with_its_fmu_section():
    m = Mapping.from_text('[fmu]\nstep = 0.1\nintegrator = "sdirk3"\nguid = "{3f2504e0-4f89-11d3-9a0c-0305e82c3301}"\n'
                          + MAPPING.replace("format = 1\n", ""))
    assert m.info == {"step": 0.1, "integrator": "sdirk3", "guid": "{3f2504e0-4f89-11d3-9a0c-0305e82c3301}"}
    assert Mapping.from_text(m.to_toml()) == m
