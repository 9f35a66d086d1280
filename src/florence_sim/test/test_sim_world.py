"""World files, the shipped apartment and its generated map (no ROS processes)."""

import itertools
import math
import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import rospkg
import yaml
from florence_sim.people import Person, check_path, load_people
from florence_sim.world import ROOMS, WorldError, load_world

from florence_common.maps import maps_dir
from florence_sim import mapgen

pytestmark = pytest.mark.unit

MAPS = maps_dir()
APARTMENT = MAPS / "apartment" / "apartment.world.yaml"
TYPES = MAPS / "florence_types.yaml"
# base_laser_link height of the Florence TurtleBot; the map test below reads it from the description
LASER_HEIGHT = 0.1648


@pytest.fixture(scope="module")
def apartment():
    return load_world(APARTMENT)


def test_apartment_has_the_five_rooms_with_hotspots_inside(apartment):
    assert set(apartment.rooms) == set(ROOMS)
    for room in apartment.rooms.values():
        x, y, _ = room.hotspot
        assert apartment.room_at(x, y) == room.name
        clearance, _ = apartment.scene.clearance([[x, y]], z_max=1.0)
        assert clearance[0] > 0.35, f"hotspot of {room.name} too close to an obstacle"
    (x0, y0), (x1, y1) = apartment.bounds
    assert 7.5 <= x1 - x0 - 1.0 <= 10.5 and 9.0 <= y1 - y0 - 1.0 <= 11.0  # about 8 x 10 m


def test_shipped_map_equals_a_fresh_generation(apartment):
    """The repo ships generated files; regenerate with `rosrun florence_sim generate_map`."""
    height = mapgen.laser_height_from_description()
    assert height == pytest.approx(LASER_HEIGHT, abs=1e-3)
    files = mapgen.generate(apartment, height, "apartment", mapgen.robot_height_from_description())
    assert "apartment_keepout.pgm" in files and "apartment_keepout.yaml" in files
    for name, data in files.items():
        shipped = (MAPS / "apartment" / name).read_bytes()
        assert shipped == data, f"maps/apartment/{name} is stale: run generate_map"


def test_map_is_map_server_format_with_legs_not_table_top(apartment):
    meta = yaml.safe_load((MAPS / "apartment" / "apartment.yaml").read_text())
    assert meta["resolution"] == 0.05 and meta["origin"] == [-0.5, -0.5, 0.0] and meta["negate"] == 0
    image = mapgen.rasterize(apartment, LASER_HEIGHT)
    assert set(np.unique(image)) == {0, 205, 254}

    def cell(x, y):
        row = image.shape[0] - 1 - int((y - meta["origin"][1]) / 0.05)
        return image[row, int((x - meta["origin"][0]) / 0.05)]

    # dining table at (3.4, 3.8), 1.2 x 0.8 m, legs at +-0.55, +-0.35
    assert cell(3.4, 3.8) == 254, "the table top is above the laser: free under it"
    for dx in (-0.55, 0.55):
        for dy in (-0.35, 0.35):
            assert cell(3.4 + dx, 3.8 + dy) == 0, "table legs are occupied"
    assert cell(0.0, 3.0) == 0  # west wall
    assert cell(-0.4, 3.0) == 205  # outside the apartment: unknown
    assert cell(2.45, 5.5) == 254  # living room door


def test_keepout_map_marks_what_the_robot_runs_into_above_the_laser(apartment):
    """rasterize(top=robot height): table tops and chair seats, which the laser passes under, are
    occupied; the rest is the laser's map."""
    laser = mapgen.rasterize(apartment, LASER_HEIGHT)
    keepout = mapgen.rasterize(apartment, LASER_HEIGHT, top=0.94)
    origin = (-0.5, -0.5)

    def cell(image, x, y):
        row = image.shape[0] - 1 - int((y - origin[1]) / 0.05)
        return image[row, int((x - origin[0]) / 0.05)]

    assert cell(laser, 3.4, 3.8) == 254 and cell(keepout, 3.4, 3.8) == 0  # under the dining table
    assert cell(laser, 2.45, 3.8) == 254 and cell(keepout, 2.45, 3.8) == 0  # chair_west's seat
    assert cell(keepout, 2.45, 5.5) == 254  # the living room door stays free
    assert np.all(keepout[laser == 0] == 0)  # everything the laser sees stays occupied
    assert np.all((keepout == 205) == (laser == 205))  # the same rooms


def test_overhang_map_holds_only_what_the_laser_passes_under(apartment):
    laser = mapgen.rasterize(apartment, LASER_HEIGHT)
    keepout = mapgen.rasterize(apartment, LASER_HEIGHT, top=0.94)
    overhang = mapgen.overhang(laser, keepout)
    origin = (-0.5, -0.5)

    def cell(image, x, y):
        row = image.shape[0] - 1 - int((y - origin[1]) / 0.05)
        return image[row, int((x - origin[0]) / 0.05)]

    assert cell(overhang, 3.4, 3.8) == 0  # the dining table's top
    assert cell(overhang, 2.45, 3.8) == 0  # chair_west's seat
    assert cell(overhang, 3.95, 4.15) == 254  # a table leg: the laser sees it
    assert cell(overhang, 0.0, 3.0) == 254  # the west wall: the laser sees it
    assert np.all((overhang == 0) == ((keepout == 0) & (laser != 0)))
    assert np.all((overhang == 205) == (laser == 205))
    assert (overhang == 0).sum() > 0.5 / 0.05**2  # the dining table alone is 1.2 x 0.8 m
    # a robot lower than the table top could go under it
    assert cell(mapgen.rasterize(apartment, LASER_HEIGHT, top=0.5), 3.4, 3.8) == 254


def test_rooms_yaml_lists_polygons_and_hotspots(apartment):
    data = yaml.safe_load((MAPS / "apartment" / "rooms.yaml").read_text())
    assert data["frame_id"] == "map"
    for name in ROOMS:
        room = data["rooms"][name]
        assert len(room["polygon"]) >= 3
        assert set(room["hotspot"]) == {"x", "y", "phi"}


def _write_world(tmp_path, text):
    (tmp_path / "types.yaml").write_text(TYPES.read_text())
    path = tmp_path / "bad.world.yaml"
    path.write_text(text)
    return path


GOOD = """
include: [types.yaml]
map: {resolution: 0.05, bounds: [[0, 0], [4, 4]]}
walls:
  - {type: wall, from: [0, 0], to: [4, 0]}
objects:
  - {type: chair, name: c1, pose: [2, 2, 0]}
"""


@pytest.mark.parametrize(
    ("replace", "field"),
    [
        (("resolution: 0.05", "resolution: -1"), "map.resolution"),
        (("resolution: 0.05", "resolution: abc"), "map.resolution"),
        (("to: [4, 0]", "to: [4]"), "walls[0].to"),
        (("type: wall", "type: wal"), "walls[0].type"),
        (("type: chair", "type: wall"), "objects[0].type"),
        (("pose: [2, 2, 0]", "pose: [2, 2, .nan]"), "objects[0].pose[2]"),
        (("pose: [2, 2, 0]", "pos: [2, 2, 0]"), "objects[0].pose"),
        (("bounds: [[0, 0], [4, 4]]", "bounds: [[0, 0], [-4, 4]]"), "map.bounds"),
        (("include: [types.yaml]", "include: [missing.yaml]"), "file"),
    ],
)
def test_malformed_world_names_file_and_field(tmp_path, replace, field):
    path = _write_world(tmp_path, GOOD.replace(*replace))
    with pytest.raises(WorldError) as err:
        load_world(path)
    assert field in str(err.value)
    assert ("missing.yaml" if field == "file" else str(path)) in str(err.value)


def test_good_synthetic_world_loads(tmp_path):
    world = load_world(_write_world(tmp_path, GOOD))
    assert len(world.scene.boxes) == 1 + 2  # wall, chair seat and backrest
    assert len(world.scene.cylinders) == 4


def test_not_yaml_is_reported(tmp_path):
    path = _write_world(tmp_path, "map: [unclosed")
    with pytest.raises(WorldError, match="not valid YAML"):
        load_world(path)


def test_person_path_through_a_wall_is_refused(apartment, tmp_path):
    # from the living room straight north through the corridor wall (no door at x = 4)
    person = Person("eve", path=[(4.0, 4.5), (4.0, 6.2)])
    with pytest.raises(WorldError, match=r"person eve: path segment 0 .*corridor_s_2"):
        check_path(person, apartment.scene)
    # the same trip through the living room door is fine
    check_path(Person("eve", path=[(2.45, 4.5), (2.45, 6.2)]), apartment.scene)


def test_people_file_is_validated(apartment, tmp_path):
    path = tmp_path / "people.yaml"
    path.write_text("people:\n  - {id: a, path: [[4.0, 4.5], [4.0, 6.2]]}\n")
    with pytest.raises(WorldError, match=str(path)):
        load_people(path, apartment.scene)
    path.write_text("people:\n  - {id: a, pose: [1, 2]}\n")
    with pytest.raises(WorldError, match=r"people\[0\]\.pose"):
        load_people(path, apartment.scene)
    path.write_text("people:\n  - {id: a, pose: [1, 3, 0], mode: run}\n")
    with pytest.raises(WorldError, match=r"people\[0\]\.mode"):
        load_people(path, apartment.scene)


def test_shipped_people_are_valid(apartment):
    people = load_people(MAPS / "apartment" / "people.yaml", apartment.scene)
    assert len(people) == 2 and all(p.walking for p in people)
    assert math.isclose(people[0].speed, 0.5)
    assert len({p.height for p in people}) == 2 and len({p.build for p in people}) == 2  # two different bodies


def test_florence_locator_config_matches_the_apartment(apartment):
    """florence_locator's shipped rooms and hotspots are the apartment's (one source: the world file)."""
    config = pathlib.Path(rospkg.RosPack().get_path("florence_locator")) / "config"
    rooms = yaml.safe_load((config / "rooms.yaml").read_text())["rooms"]
    hotspots = yaml.safe_load((config / "hotspots.yaml").read_text())["hotspots"]
    assert set(rooms) == set(hotspots) == set(apartment.rooms)
    for name, room in apartment.rooms.items():
        assert rooms[name] == room.polygon
        assert (hotspots[name]["x"], hotspots[name]["y"], hotspots[name]["phi"]) == pytest.approx(room.hotspot)


def test_the_simulator_launch_file_defaults_to_the_shipped_world():
    """Its world and people arguments resolve (through FLORENCE_MAPS, no path arithmetic) to the files here."""
    from roslaunch.substitution_args import resolve_args

    launch = pathlib.Path(rospkg.RosPack().get_path("florence_sim")) / "launch" / "florence_sim.launch"
    args = {a.get("name"): a.get("default") for a in ET.parse(launch).getroot().iter("arg")}
    for name, shipped in (("world", APARTMENT), ("people", MAPS / "apartment" / "people.yaml")):
        assert args[name].startswith("$(env FLORENCE_MAPS)/") and "../" not in args[name], args[name]
        resolved = pathlib.Path(resolve_args(args[name]))
        assert resolved == shipped and resolved.is_file(), resolved


def test_simulator_from_files_builds_the_robot_of_its_description(apartment, tmp_path):
    """One factory for the node, the offline runs and the benchmarks: world, people, robot, base, start."""
    from florence_sim.robot_model import RobotModel
    from florence_sim.sim import SimConfig, Simulator

    robot = RobotModel.from_xacro()
    people = MAPS / "apartment" / "people.yaml"
    sim = Simulator.from_files(APARTMENT, people, robot, SimConfig(seed=3), (1.2, 3.0, 0.3), gyro_scale_error=0.05)
    assert sim.world.path == str(APARTMENT) and set(sim.people) == {"alice", "bob"}
    assert (sim.base.x, sim.base.y, sim.base.yaw) == (1.2, 3.0, 0.3) and sim.cfg.seed == 3
    cfg = sim.base.cfg
    assert (cfg.radius, cfg.wheel_separation) == pytest.approx((0.1696, 0.26))
    assert cfg.height == pytest.approx(robot.height()) and cfg.gyro_scale_error == 0.05
    assert sim.laser.mount[2, 3] == pytest.approx(LASER_HEIGHT, abs=1e-3)
    for nobody in (None, ""):
        assert Simulator.from_files(APARTMENT, nobody, robot, start=(1.0, 2.5, 0.0)).people == {}
    with pytest.raises(ValueError, match="puts the robot into"):
        Simulator.from_files(APARTMENT, None, robot, start=(0.0, 0.0, 0.0))
    with pytest.raises(TypeError):
        Simulator.from_files(APARTMENT, None, robot, no_such_field=1.0)
    with pytest.raises(WorldError, match=r"missing\.world\.yaml"):
        Simulator.from_files(tmp_path / "missing.world.yaml", None, robot)


def test_generate_map_command_writes_the_files_and_reports_bad_worlds(tmp_path, capsys):
    assert mapgen.main([str(APARTMENT), "--out-dir", str(tmp_path), "--laser-height", str(LASER_HEIGHT)]) == 0
    assert (tmp_path / "apartment.pgm").read_bytes() == (MAPS / "apartment" / "apartment.pgm").read_bytes()
    assert (tmp_path / "apartment_keepout.pgm").read_bytes() == (MAPS / "apartment" /
                                                                 "apartment_keepout.pgm").read_bytes()
    assert not list(tmp_path.glob(".tmp-*")), "temporary files left behind"
    assert mapgen.main([str(tmp_path / "missing.world.yaml")]) == 2
    assert "missing.world.yaml: file: cannot read" in capsys.readouterr().err


def test_sitting_person_cannot_walk(apartment, tmp_path):
    path = tmp_path / "people.yaml"
    path.write_text("people:\n  - {id: a, posture: sitting, path: [[1.2, 3.0], [1.2, 4.0]]}\n")
    with pytest.raises(WorldError, match=r"people\[0\]\.posture: a sitting person cannot walk"):
        load_people(path, apartment.scene)


def test_people_file_takes_height_and_build(apartment, tmp_path):
    path = tmp_path / "people.yaml"
    path.write_text("people:\n  - {id: a, pose: [1.2, 3.0, 0], height: 1.9, build: 1.2}\n"
                    "  - {id: b, pose: [1.2, 4.0, 0]}\n")
    tall, plain = load_people(path, apartment.scene)
    assert (tall.height, tall.build) == (1.9, 1.2) and (plain.height, plain.build) == (1.72, 1.0)
    assert max(c.z1 for c in tall.primitives()) == pytest.approx(1.9)


@pytest.mark.parametrize(("entry", "field", "problem"), [
    ("height: 2.3", r"people\[0\]\.height", "must be <= 2.05"),
    ("height: 1.2", r"people\[0\]\.height", "must be >= 1.4"),
    ("height: tall", r"people\[0\]\.height", "expected a finite number"),
    ("build: 1.5", r"people\[0\]\.build", "must be <= 1.35"),
    ("build: 0.5", r"people\[0\]\.build", "must be >= 0.75"),
    ("build: .nan", r"people\[0\]\.build", "expected a finite number"),
    ("heigth: 1.9", r"people\[0\]\.heigth", "unknown key 'heigth' \\(did you mean 'height'\\?\\)"),
    ("colour: [1, 0, 0]", r"people\[0\]\.colour", "unknown key 'colour'"),
])
def test_bad_height_build_and_unknown_keys_are_refused_naming_the_key(apartment, tmp_path, entry, field, problem):
    path = tmp_path / "people.yaml"
    path.write_text(f"people:\n  - {{id: a, pose: [1.2, 3.0, 0], {entry}}}\n")
    with pytest.raises(WorldError, match=f"{path}: {field}: {problem}"):
        load_people(path, apartment.scene)


def test_set_person_specs_are_checked_the_same_way():
    """The node's ~set_person service builds its person with person_from_spec, as a people file."""
    from florence_sim.people import person_from_spec
    from florence_sim.world import _Reader

    with pytest.raises(WorldError, match=r"^set_person: spec\.heigth: unknown key 'heigth'"):
        person_from_spec({"id": "v", "pose": [1, 2, 0], "heigth": 1.9}, _Reader("set_person"), "spec")
    with pytest.raises(WorldError, match=r"^set_person: spec\.build: must be <= 1\.35"):
        person_from_spec({"id": "v", "pose": [1, 2, 0], "build": 2}, _Reader("set_person"), "spec")
    person = person_from_spec({"id": "v", "pose": [1, 2, 0], "height": 1.6, "build": 0.9}, _Reader("set_person"),
                              "spec")
    assert (person.height, person.build) == (1.6, 0.9)


# ------------------------------------------------------------------ person-sized clutter
CLUTTER = ("coat_stand", "floor_lamp", "tall_plant")  # types, and the names of their objects in the apartment
# the doorways of maps/apartment/apartment.world.yaml: the middle of each gap in the walls [m]
DOORWAYS = {"living_room": (2.45, 5.5), "kitchen": (6.45, 5.5), "bedroom": (1.45, 6.8), "bathroom": (6.6, 6.8),
            "living_kitchen_opening": (5.0, 2.25)}


def _only(scene, keep):
    """The scene's primitives whose object name (before the '/') ``keep`` accepts."""
    from florence_sim.geometry import Scene

    return Scene([b for b in scene.boxes if keep(b.name.split("/")[0])],
                 [c for c in scene.cylinders if keep(c.name.split("/")[0])], scene.ceiling)


def test_person_sized_clutter_types_have_their_dimensions():
    from florence_sim.world import instantiate, load_types

    types = load_types(TYPES)

    def parts(name):
        boxes, cylinders = instantiate(types[name], name, 0.0, 0.0, 0.0)
        return boxes, cylinders

    boxes, cyls = parts("coat_stand")
    assert max(c.z1 for c in cyls) == pytest.approx(1.75)
    (coat,) = boxes
    assert (coat.z0, coat.z1) == pytest.approx((1.10, 1.60)) and 0.4 <= coat.sy <= 0.5  # a coat hangs there
    assert min(c.z0 for c in cyls) == 0.0 and max(c.radius for c in cyls if c.z1 < 0.1) >= 0.2  # base disc
    boxes, cyls = parts("floor_lamp")
    shade = max(cyls, key=lambda c: c.z1)
    assert not boxes and 1.6 <= shade.z1 <= 1.7 and shade.radius == pytest.approx(0.20)
    assert min(c.radius for c in cyls) < 0.02  # a thin pole
    boxes, cyls = parts("tall_plant")
    pot = min(cyls, key=lambda c: c.z0)
    assert not boxes and pot.radius == pytest.approx(0.18) and pot.z1 == pytest.approx(0.40)
    assert 0.5 <= 2 * max(c.radius for c in cyls) <= 0.7 and max(c.z1 for c in cyls) == pytest.approx(1.80)


@pytest.mark.parametrize(("name", "robot_xy"), [("coat_stand", (2.9, 4.7)), ("floor_lamp", (2.6, 2.6)),
                                                ("tall_plant", (2.8, 2.6))])
def test_the_kinect_sees_the_apartments_clutter_up_to_head_height(apartment, name, robot_xy):
    """From 2.5-3 m the Kinect (tilted 0.25 rad up) sees each piece of clutter to above 1.5 m:
    the depth image differs from the apartment without it."""
    from florence_sim.robot_model import RobotModel
    from florence_sim.sensors import CameraConfig, DepthCamera, world_pose

    (x, y, _), = [o["pose"] for o in yaml.safe_load(APARTMENT.read_text())["objects"] if o["name"] == name]
    yaw = math.atan2(y - robot_xy[1], x - robot_xy[0])
    pose = world_pose(*robot_xy, yaw) @ RobotModel.from_xacro().pose("camera_depth_optical_frame",
                                                                      {"camera_tilt_joint": 0.25})
    cam = DepthCamera(CameraConfig(depth_noise=0.0, edge_dropout=0))
    seen, _ = cam.render(apartment.scene, pose)
    without, _ = cam.render(_only(apartment.scene, lambda obj: obj != name), pose)
    changed = np.isfinite(seen) & ~(np.abs(seen - without) < 0.05)
    assert changed.sum() > 150, f"{name}: {changed.sum()} pixels"
    z = (cam.points(seen)[changed] @ pose[:3, :3].T + pose[:3, 3])[:, 2]
    assert z.max() > 1.5 and z.min() < 1.0, f"{name} seen from {z.min():.2f} to {z.max():.2f} m"


def test_the_apartments_clutter_keeps_clear_of_people_hotspots_and_doorways(apartment):
    """At least 0.5 m from every shipped person's path, 0.6 m from every room's hotspot and doorway
    (distances from the clutter's footprint at any height up to 2.1 m)."""
    clutter = _only(apartment.scene, lambda obj: obj in CLUTTER)
    assert {n.split("/")[0] for n in clutter.names} == set(CLUTTER)
    for person in load_people(MAPS / "apartment" / "people.yaml", apartment.scene):
        points = np.concatenate([np.linspace(a, b, 200) for a, b in itertools.pairwise(person.path)])
        gap, owner = clutter.clearance(points, z_max=2.1)
        assert gap.min() >= 0.5, f"{clutter.names[owner[gap.argmin()]]} {gap.min():.2f} m from {person.id}'s path"
    places = {f"hotspot {n}": r.hotspot[:2] for n, r in apartment.rooms.items()}
    places.update({f"doorway {n}": xy for n, xy in DOORWAYS.items()})
    for what, xy in places.items():
        gap, owner = clutter.clearance([xy], z_max=2.1)
        assert gap[0] >= 0.6, f"{clutter.names[owner[0]]} {gap[0]:.2f} m from the {what}"
