"""Loading any arm from a URDF: the chain, its frames and masses (Drake's as reference),
mesh formats and package paths, and the refusals, one line each."""

import re
import shutil

import numpy as np
import pytest
import trimesh
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from safety_systems.cell import ur_family
from safety_systems.cell.capsule_fit import enclosure_slack, fit_link_capsules
from safety_systems.cell.robot_description import load_robot_description
from safety_systems.files.input_error import InputError

PANDA = ur_family.MODELS / "panda" / "panda.urdf"


def test_ur5e_chain():
    d = load_robot_description(ur_family.UR5E.urdf)
    assert d.num_joints == 6 and d.joint_names == ur_family.JOINT_NAMES
    assert d.tool_frame == "tool0" and d.base_link == "base_link"
    assert d.link_names == ur_family.LINK_NAMES == d.collision_links
    assert d.static_links == ("base_link",) and d.off_chain_links == ()
    np.testing.assert_array_equal(d.masses, ur_family.UR5E.link_masses)
    np.testing.assert_array_equal(d.velocity_limit, ur_family.UR5E.velocity_limits)
    np.testing.assert_array_equal(d.position_upper, ur_family.UR5E.position_upper)
    assert set(d.joint_types) == {"revolute"} and not d.kinds.any()
    import hashlib
    assert d.sha256 == hashlib.sha256(ur_family.UR5E.urdf.read_bytes()).hexdigest()


def test_panda_chain_and_hand():
    """Default tool: the hand (its fingers branch off it); the fingers are off the chain;
    panda_link8 and panda_hand_tcp (frames) need no capsule; the hand rides on body 7."""
    d = load_robot_description(PANDA)
    assert d.num_joints == 7 and d.tool_frame == "panda_hand"
    assert set(d.off_chain_links) == {"panda_leftfinger", "panda_rightfinger"}
    assert d.collision_links[-1] == "panda_hand" and d.collision_bodies[-1] == 7
    assert "panda_link8" not in d.collision_links and "panda_hand_tcp" not in d.collision_links
    np.testing.assert_array_equal(d.position_lower[3:4], [-3.0718])
    np.testing.assert_array_equal(d.velocity_limit, [2.175] * 4 + [2.61] * 3)
    np.testing.assert_array_equal(d.effort_limit, [87.0] * 4 + [12.0] * 3)
    tcp = load_robot_description(PANDA, tool_frame="panda_hand_tcp")
    np.testing.assert_allclose(tcp.X_tool[:3, 3], [0.0, 0.0, 0.107 + 0.1034], atol=1e-15)
    flange = load_robot_description(PANDA, tool_frame="panda_link8")
    assert flange.collision_links == d.collision_links  # the hand still moves with link 7


@pytest.mark.parametrize("urdf", [PANDA, ur_family.UR20.urdf], ids=lambda p: p.stem)
def test_body_masses_match_drake(urdf):
    """Each body's mass, centre of mass and inertia (its welded links combined) equal
    Drake's spatial inertia of the same links about the body's frame."""
    d = load_robot_description(urdf)
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(d.base_link), RigidTransform())
    plant.Finalize()
    context = plant.CreateDefaultContext()
    for k, link in enumerate(d.link_names):
        frame = plant.GetFrameByName(link)
        members = [b.index() for b in plant.GetBodiesWeldedTo(plant.GetBodyByName(link))]
        M = plant.CalcSpatialInertia(context, frame, members)
        assert d.masses[k] == pytest.approx(M.get_mass(), abs=1e-12)
        np.testing.assert_allclose(d.coms[k], M.get_com(), atol=1e-12)
        M_com = M.Shift(M.get_com())
        np.testing.assert_allclose(d.inertias[k], M_com.CalcRotationalInertia().CopyToFullMatrix3(),
                                   atol=1e-12)


def _one_link_urdf(folder, geometry: str, *, link_extra: str = "", joint_type="revolute"):
    text = f"""<?xml version="1.0"?>
<robot name="test">
  <link name="base"/>
  <link name="arm">{link_extra}
    <collision><origin xyz="0 0 0.1" rpy="0 0 0"/><geometry>{geometry}</geometry></collision>
  </link>
  <joint name="j" type="{joint_type}">
    <parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""
    path = folder / "test.urdf"
    path.write_text(text)
    return path


@pytest.mark.parametrize("suffix", ["stl", "obj", "dae"])
def test_mesh_formats_and_scale(tmp_path, suffix):
    """A box mesh in each format, scaled by <mesh scale>: its vertices as placed, and the
    fitted capsule encloses them."""
    box = trimesh.creation.box(extents=(0.1, 0.2, 0.3))
    (tmp_path / "meshes").mkdir()
    box.export(str(tmp_path / "meshes" / f"box.{suffix}"))
    urdf = _one_link_urdf(tmp_path, f'<mesh filename="meshes/box.{suffix}" scale="2 1 0.5"/>')
    d = load_robot_description(urdf)
    (shape,) = d.collision_shapes[0]
    lo, hi = shape.vertices.min(axis=0), shape.vertices.max(axis=0)
    np.testing.assert_allclose(hi - lo, [0.2, 0.2, 0.15], atol=1e-6)
    np.testing.assert_allclose(shape.X_BG[:3, 3], [0, 0, 0.1])
    assert enclosure_slack(d, fit_link_capsules(d))[0] >= 0.0


def test_package_paths(tmp_path):
    """package://NAME/... resolves to a folder NAME beside the URDF, or one given."""
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    (tmp_path / "mypkg" / "meshes").mkdir(parents=True)
    box.export(str(tmp_path / "mypkg" / "meshes" / "box.obj"))
    geometry = '<mesh filename="package://mypkg/meshes/box.obj"/>'
    assert load_robot_description(_one_link_urdf(tmp_path, geometry)).num_joints == 1
    elsewhere = tmp_path / "other"
    elsewhere.mkdir()
    urdf = _one_link_urdf(elsewhere, geometry)
    with pytest.raises(InputError, match="package folder named 'mypkg'"):
        load_robot_description(urdf)
    d = load_robot_description(urdf, package_paths={"mypkg": tmp_path / "mypkg"})
    assert d.collision_shapes[0][0].file == str(tmp_path / "mypkg" / "meshes" / "box.obj")


def _refusal(call) -> str:
    with pytest.raises(InputError) as info:
        call()
    line = str(info.value)
    assert "\n" not in line
    return line


def test_refusals_one_line_each(tmp_path):
    not_urdf = tmp_path / "scene.xml"
    not_urdf.write_text("<sdf version='1.9'/>")
    line = _refusal(lambda: load_robot_description(not_urdf))
    assert line.startswith(f"{not_urdf}: robot: ") and "URDF" in line
    garbage = tmp_path / "garbage.urdf"
    garbage.write_text("not xml at all")
    assert "URDF" in _refusal(lambda: load_robot_description(garbage))

    line = _refusal(lambda: load_robot_description(PANDA, base_link="panda_link3",
                                                   tool_frame="panda_link1"))
    assert "tool_frame" in line and "no chain" in line
    assert "no moving joint" in _refusal(lambda: load_robot_description(
        PANDA, tool_frame="panda_link0"))
    assert "a link of the file" in _refusal(lambda: load_robot_description(
        PANDA, tool_frame="gripper"))

    planar = _one_link_urdf(tmp_path, '<box size="0.1 0.1 0.1"/>', joint_type="planar")
    line = _refusal(lambda: load_robot_description(planar))
    assert "joint j.type: got 'planar'" in line

    missing = _one_link_urdf(tmp_path, '<mesh filename="meshes/absent.stl"/>')
    line = _refusal(lambda: load_robot_description(missing))
    assert "link arm.collision[0].mesh.filename" in line and "absent.stl" in line

    ur = (tmp_path / "ur5e.urdf")
    text = ur_family.UR5E.urdf.read_text()
    start = text.index('<link name="forearm_link">')
    end = text.index("</link>", start)
    link = re.sub(r"<collision>.*?</collision>", "", text[start:end], flags=re.DOTALL)
    ur.write_text(text[:start] + link + text[end:])
    line = _refusal(lambda: load_robot_description(ur))
    assert line.startswith(f"{ur}: link forearm_link.collision: ") and "visual" in line


def test_frame_links_are_merged_not_refused(tmp_path):
    """A massless link with no geometry after a moving joint (a frame) needs no capsule;
    one with mass but no collision geometry is refused."""
    shutil.copytree(PANDA.parent / "meshes", tmp_path / "meshes")
    text = PANDA.read_text()
    (tmp_path / "p.urdf").write_text(text)
    d = load_robot_description(tmp_path / "p.urdf", tool_frame="panda_link8")
    assert "panda_link8" not in d.collision_links
    heavy = text.replace('<link name="panda_link8"/>', '<link name="panda_link8"><inertial>'
                         '<mass value="0.1"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" '
                         'iyz="0" izz="1e-4"/></inertial></link>')
    (tmp_path / "heavy.urdf").write_text(heavy)
    assert "link panda_link8.collision" in _refusal(
        lambda: load_robot_description(tmp_path / "heavy.urdf"))


def test_panda_loads_in_drake_with_its_geometry():
    """Drake's SceneGraph takes the Panda's OBJ meshes (9) and finger boxes (8)."""
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModels(str(PANDA))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("panda_link0"), RigidTransform())
    plant.Finalize()
    builder.Build()
    assert plant.num_positions() == 9  # 7 arm joints, 2 fingers
    assert scene_graph.model_inspector().num_geometries() == 9 + 8
