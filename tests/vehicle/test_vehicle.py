"""Vehicle loading and URDF generation (masses and inertia seen by PyBullet)."""

from __future__ import annotations

import pytest
from lxml import etree

from vinecli.errors import SpecError
from vinecli.vehicle import VEHICLES_DIR, known_vehicles, load_vehicle
from vinecli.vehicle.urdf import link_names, rigid_inertia, vehicle_urdf, write_urdf
from vinecli.world.engine import Engine

URDF_TAGS = {"robot", "link", "joint", "inertial", "origin", "mass", "inertia", "visual", "collision", "geometry",
             "box", "cylinder", "parent", "child"}


def test_load_by_name_and_path(tmp_path):
    assert {"x500", "x500-sprayer", "hex-sprayer"} <= set(known_vehicles())
    v = load_vehicle("x500-sprayer")
    assert v.tank is not None and v.tank.capacity_l == 1.0
    assert load_vehicle(VEHICLES_DIR / "x500.yaml").name == "x500"
    with pytest.raises(SpecError, match="known: .*x500"):
        load_vehicle("no-such-drone")
    with pytest.raises(SpecError, match="not found"):
        load_vehicle(tmp_path / "missing.yaml")


@pytest.mark.parametrize("name", ["x500", "x500-sprayer", "hex-sprayer"])
def test_urdf_masses_and_inertia_in_pybullet(tmp_path, name):
    v = load_vehicle(name)
    v = v.model_copy(update={"payload": v.payload.model_copy(update={"mass_kg": 0.4})})
    urdf = write_urdf(v, tmp_path / f"{name}.urdf")
    tags = {el.tag for el in etree.parse(str(urdf)).iter()}
    assert tags <= URDF_TAGS  # no custom tags
    with Engine() as e:
        b = e.load_vehicle(urdf, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0))
        c = e.client
        info = c.getDynamicsInfo(b, -1)
        assert info[0] == pytest.approx(v.frame.mass_kg)
        assert info[2] == pytest.approx(v.frame.inertia_kgm2)
        names = [c.getJointInfo(b, j)[12].decode() for j in range(c.getNumJoints(b))]
        assert names == link_names(v)
        total = sum(c.getDynamicsInfo(b, link)[0] for link in range(-1, c.getNumJoints(b)))
        assert total == pytest.approx(v.dry_mass())
        for j, rotor in enumerate(v.rotors):
            assert c.getDynamicsInfo(b, j)[0] == pytest.approx(v.motor.rotor_mass_kg)
            assert c.getJointInfo(b, j)[2] == c.JOINT_FIXED
            assert c.getJointInfo(b, j)[14] == pytest.approx(rotor.position_m)
        if v.tank is not None:
            k = names.index("tank")
            assert c.getDynamicsInfo(b, k)[0] == 0.0  # the liquid is a force, not a mass
            assert c.getJointInfo(b, k)[14] == pytest.approx(v.tank.mount_m)
        # the whole body: PyBullet's merged inertia equals the parallel-axis sum
        b2 = c.loadURDF(str(urdf), [3, 0, 1], flags=c.URDF_MERGE_FIXED_LINKS | c.URDF_USE_INERTIA_FROM_FILE)
        m, com, inertia = rigid_inertia(v)
        assert c.getDynamicsInfo(b2, -1)[0] == pytest.approx(m)
        assert sum(c.getDynamicsInfo(b2, -1)[2]) == pytest.approx(sum(inertia), rel=1e-6)


def test_collision_box_bottom_at_the_skids():
    v = load_vehicle("x500")
    root = etree.fromstring(vehicle_urdf(v).encode())
    col = root.find("link[@name='base_link']/collision")
    z = float(col.find("origin").get("xyz").split()[2])
    h = float(col.find("geometry/box").get("size").split()[2])
    assert z - h / 2 == pytest.approx(-v.frame.landing_gear_height_m)
