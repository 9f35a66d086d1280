"""Rooms (labelled polygons: edges, shared edges, outside every room), hotspots files and the map
check of hotspots and goals."""

import math

import numpy as np
import pytest
from florence_locator.places import (
    UNKNOWN,
    FloorMap,
    Hotspots,
    Pose,
    Rooms,
    check_label,
    check_pose,
    contains,
    contains_points,
)

from florence_common.grid import Grid
from florence_common.maps import map_file
from florence_common.yamlfile import YamlError

pytestmark = pytest.mark.unit

SQUARE = [[0, 0], [2, 0], [2, 2], [0, 2]]
# an L-shaped (concave) room: the notch (1.5, 1.5) is outside
L_SHAPE = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]


@pytest.fixture(scope="module")
def apartment():
    return Rooms.load(map_file("apartment", "rooms.yaml"))


@pytest.mark.parametrize("x, y, inside", [
    (1, 1, True), (0, 0, True), (2, 2, True), (1, 0, True), (0, 1.3, True), (2, 0.5, True),  # corners and edges
    (2.0000001, 1, True),  # within the edge tolerance
    (2.001, 1, False), (-0.01, 1, False), (1, 2.01, False), (5, 5, False),
])
def test_square_holds_its_inside_edges_and_corners(x, y, inside):
    assert contains(SQUARE, x, y) is inside


@pytest.mark.parametrize("x, y, inside", [(0.5, 1.5, True), (1.5, 0.5, True), (1.5, 1.5, False), (1.0, 1.5, True),
                                          (1.5, 1.0, True), (1.2, 1.2, False)])
def test_concave_room(x, y, inside):
    assert contains(L_SHAPE, x, y) is inside


@pytest.mark.parametrize("x, y, room", [
    (1.2, 3.0, "living_room"), (6.3, 2.5, "kitchen"), (3.0, 6.15, "corridor"), (1.2, 7.6, "bedroom"),
    (6.5, 7.7, "bathroom"),
    # shared edges (wall centre lines): the first room of the file in order (bathroom, bedroom, corridor, kitchen,
    # living_room) that holds the point
    (5.0, 2.0, "kitchen"),  # living room | kitchen
    (3.0, 5.5, "corridor"),  # corridor | living room
    (1.5, 6.8, "bedroom"),  # bedroom | corridor
    (5.5, 8.0, "bathroom"),  # bathroom | bedroom
    (5.5, 6.8, "bathroom"),  # the corner of three rooms
    (0.0, 0.0, "living_room"), (8.0, 10.0, "bathroom"),  # outer corners
    # outside every room
    (-0.1, 3.0, UNKNOWN), (8.2, 1.0, UNKNOWN), (4.0, 10.5, UNKNOWN), (-100.0, -100.0, UNKNOWN),
    (math.nan, 1.0, UNKNOWN), (1.0, math.inf, UNKNOWN),
])
def test_apartment_room_lookup(apartment, x, y, room):
    assert apartment.room_at(x, y) == room


def test_many_points_at_once_agree_with_one_at_a_time(apartment):
    rng = np.random.default_rng(2)
    pts = np.vstack([rng.uniform([-0.5, -0.5], [8.5, 10.5], size=(400, 2)),
                     [[5.0, 2.0], [3.0, 5.5], [5.5, 6.8], [0.0, 0.0], [8.0, 10.0], [math.nan, 1.0]]])
    assert list(apartment.rooms_at(pts)) == [apartment.room_at(x, y) for x, y in pts]
    for x, y in rng.uniform(-0.2, 2.2, size=(200, 2)):
        assert contains_points(L_SHAPE, [[x, y]])[0] == contains(L_SHAPE, x, y)


def test_rooms_file_beside_the_map_and_the_locator_config_agree(apartment):
    """The map's rooms.yaml ({polygon, hotspot} per room) and florence_locator's config/rooms.yaml (polygons only)
    give the same lookup; the map's file also carries a hotspot per room."""
    import rospkg

    config = Rooms.load(f"{rospkg.RosPack().get_path('florence_locator')}/config/rooms.yaml")
    assert set(config.labels()) == set(apartment.labels()) == {"living_room", "kitchen", "corridor", "bedroom",
                                                               "bathroom"}
    rng = np.random.default_rng(1)
    for x, y in rng.uniform([-0.5, -0.5], [8.5, 10.5], size=(300, 2)):
        room = config.room_at(x, y)
        assert room == apartment.room_at(x, y) or (room != UNKNOWN and apartment.room_at(x, y) != UNKNOWN)
    assert apartment.hotspots["bedroom"] == Pose(1.2, 7.6, pytest.approx(1.5707963))
    assert config.hotspots == {}


@pytest.mark.parametrize("text, line, words", [
    ("rooms:\n  hall: [[0, 0], [1, 0]]\n", 2, "at least 3 points"),
    ("rooms:\n  hall:\n    - [0, 0]\n    - [1, x]\n    - [1, 1]\n", 4, "must be a number"),
    ("rooms:\n  hall: [[0, 0], [1, 0], [2, 0]]\n", 2, "no area"),
    ("rooms:\n  unknown: [[0, 0], [1, 0], [1, 1]]\n", 2, "'unknown' is the label of places outside"),
    ("rooms:\n  hall: {polygon: [[0, 0], [1, 0], [1, 1]], hotspot: {x: 1, y: .nan, phi: 0}}\n", 2, "finite"),
    ("rooms:\n  hall: {polygn: [[0, 0], [1, 0], [1, 1]]}\n", 2, "unknown key 'polygn'"),
    ("rooms:\n  a: [[0, 0], [1, 0], [1, 1]]\n  a: [[0, 0], [1, 0], [1, 1]]\n", 3, "duplicate key"),
    ("rooms: [1, 2]\n", 1, "expected a mapping 'rooms'"),
    ("rooms:\n  hall: [[0, 0], [1, 0], [1, 1]\n", 3, "not valid YAML"),
])
def test_a_bad_rooms_file_names_the_file_and_line(tmp_path, text, line, words):
    path = tmp_path / "rooms.yaml"
    path.write_text(text)
    with pytest.raises(YamlError, match=words) as info:
        Rooms.load(path)
    assert str(info.value).startswith(f"{path}:{line}: "), str(info.value)


@pytest.mark.parametrize("text, line, words", [
    ("hotspots:\n  kitchen: {x: 1, y: 2}\n", 2, "missing phi"),
    ("hotspots:\n  kitchen: {x: 1, y: 2, phi: 0, z: 3}\n", 2, "unknown key 'z'"),
    ("hotspots:\n  kitchen:\n    x: 1\n    y: abc\n    phi: 0\n", 4, "must be a number"),
    ("hotspots:\n  kitchen: {x: .inf, y: 2, phi: 0}\n", 2, "finite"),
    ("hotspots:\n  kitchen: [1, 2, 0]\n", 2, "expected {x"),
    ("hotspot:\n  kitchen: {x: 1, y: 2, phi: 0}\n", 1, "expected a mapping 'hotspots'"),
    ("hotspots:\n  kitchen: {x: 1, y: 2, phi: 0\n", 3, "not valid YAML"),
])
def test_a_bad_hotspots_file_names_the_file_and_line(tmp_path, text, line, words):
    path = tmp_path / "hotspots.yaml"
    path.write_text(text)
    with pytest.raises(YamlError, match=words) as info:
        Hotspots.load(path)
    assert str(info.value).startswith(f"{path}:{line}: "), str(info.value)


def test_hotspots_round_trip_and_survive_a_restart(tmp_path):
    path = tmp_path / "hotspots.yaml"
    path.write_text("hotspots:\n  kitchen: {x: 6.3, y: 2.5, phi: 0.0}\n")
    spots = Hotspots.load(path)
    spots.set("tv", Pose(2.0, 1.0, 3.0))
    spots.set(" kitchen ", Pose(6.0, 2.0, -1.0))  # labels are stripped
    again = Hotspots.load(path)  # what a restarted locator reads
    assert dict(again.items()) == {"kitchen": Pose(6.0, 2.0, -1.0), "tv": Pose(2.0, 1.0, 3.0)}
    assert [p.name for p in tmp_path.iterdir()] == ["hotspots.yaml"]  # no temporary left behind
    assert Hotspots.load(tmp_path / "hotspots.yaml").get("nowhere") is None


def test_an_empty_hotspots_list_loads(tmp_path):
    path = tmp_path / "hotspots.yaml"
    path.write_text("hotspots:\n")
    assert Hotspots.load(path).labels() == []


def test_a_failed_save_keeps_the_old_value(tmp_path):
    """The file cannot be written (its folder is a file here; a read-only disk in life): the call fails and
    nothing changes, in memory or on disk."""
    (tmp_path / "not_a_folder").write_text("")
    spots = Hotspots({"kitchen": Pose(6.3, 2.5, 0.0)}, tmp_path / "not_a_folder" / "hotspots.yaml")
    with pytest.raises(OSError):
        spots.set("kitchen", Pose(1.0, 1.0, 0.0))
    with pytest.raises(OSError):
        spots.set("tv", Pose(1.0, 1.0, 0.0))
    assert dict(spots.items()) == {"kitchen": Pose(6.3, 2.5, 0.0)}


@pytest.mark.parametrize("label, ok", [("kitchen", True), ("  tv ", True), ("", False), ("   ", False),
                                       ("unknown", False), ("a\nb", False), (3, False)])
def test_labels(label, ok):
    if ok:
        assert check_label(label) == label.strip()
    else:
        with pytest.raises(ValueError):
            check_label(label)


def test_poses_must_be_finite():
    assert check_pose(1, 2, 4.0).phi == pytest.approx(4.0 - 2 * math.pi)
    for bad in ((math.nan, 0, 0), (0, math.inf, 0), (0, 0, -math.inf)):
        with pytest.raises(ValueError, match="finite"):
            check_pose(*bad)


def test_floor_map_refuses_walls_unknown_space_and_off_the_map():
    data = np.zeros((40, 60), dtype=int)  # 3 x 2 m at 5 cm, origin (-1, -1)
    data[:, 30] = 100  # a wall at x = 0.5 .. 0.55
    data[:5, :] = -1  # unknown strip at the bottom
    floor = FloorMap(data, (-1.0, -1.0, 0.0), 0.05)
    assert floor.problem(0.0, 0.0) is None
    assert "inside a wall" in floor.problem(0.52, 0.0)
    assert "unknown space" in floor.problem(0.0, -0.9)
    assert "off the map" in floor.problem(5.0, 0.0)
    assert "off the map" in floor.problem(-1.01, 0.0)
    assert "not finite" in floor.problem(math.nan, 0.0)
    assert "less than 0.15 m" in floor.problem(0.42, 0.0, clearance=0.15)
    assert floor.problem(0.2, 0.0, clearance=0.15) is None


def test_floor_map_of_the_apartment_accepts_the_shipped_hotspots():
    from map_server.mapfile import load_map

    grid = load_map(map_file("apartment", "apartment.yaml"))
    floor = FloorMap(grid.data, grid.origin, grid.resolution)
    rooms = Rooms.load(map_file("apartment", "rooms.yaml"))
    for label, spot in rooms.hotspots.items():
        assert floor.problem(spot.x, spot.y, clearance=0.15) is None, label
    assert "inside a wall" in floor.problem(5.0, 0.8)  # the living room | kitchen wall


def _room_with_a_cupboard():
    """A free 4 x 3 m room at 5 cm (walls all round) with a cupboard at x 2.0 .. 2.5, y 0.5 .. 2.5."""
    data = np.zeros((60, 80), dtype=int)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[10:50, 40:50] = 100
    return FloorMap(data, (0.0, 0.0, 0.0), 0.05), [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]]


def test_line_of_sight_stops_at_obstacles():
    floor, _room = _room_with_a_cupboard()
    seen = floor.line_of_sight([[1.0, 1.5], [1.0, 2.8], [3.5, 1.5]], (3.5, 2.8))
    assert seen.tolist() == [False, True, True]  # the cupboard is between (1.0, 1.5) and (3.5, 2.8)


def test_lookout_sees_the_searched_place_from_the_reach_away_in_the_open():
    floor, room = _room_with_a_cupboard()
    spot = floor.lookout(room, [(1.0, 1.5)], reach=1.0, clearance=0.45)
    assert math.hypot(spot.x - 1.0, spot.y - 1.5) == pytest.approx(1.0, abs=0.15)
    assert floor.problem(spot.x, spot.y, 0.45) is None
    assert math.atan2(1.5 - spot.y, 1.0 - spot.x) == pytest.approx(spot.phi)
    assert floor.line_of_sight([[spot.x, spot.y]], (1.0, 1.5))[0]
    # behind the cupboard is out of sight: the farthest visible place from (1.0, 1.5) at a long reach
    far = floor.lookout(room, [(1.0, 1.5)], reach=10.0, clearance=0.45)
    assert floor.line_of_sight([[far.x, far.y]], (1.0, 1.5))[0] and not (2.0 <= far.x <= 2.5)
    # two places searched: away from both
    two = floor.lookout(room, [(1.0, 1.5), (3.3, 1.5)], reach=1.5, clearance=0.45)
    assert min(math.hypot(two.x - 1.0, two.y - 1.5), math.hypot(two.x - 3.3, two.y - 1.5)) > 1.0


def test_lookout_from_a_search_outside_the_room_behind_a_wall():
    floor, _room = _room_with_a_cupboard()
    half = [[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]]  # west of the cupboard: (3.3, 1.5) out of its sight
    assert not floor.line_of_sight([[1.0, 1.5]], (3.3, 1.5))[0]
    spot = floor.lookout(half, [(3.3, 1.5)], reach=2.5, clearance=0.45)
    assert spot is not None and spot.x < 2.0 and floor.problem(spot.x, spot.y, 0.45) is None
    assert not floor.line_of_sight([[spot.x, spot.y]], (3.3, 1.5))[0]  # none sees it: the line is not asked
    assert floor.lookout(half, [(3.3, 1.5)], reach=2.5, clearance=0.45, need_sight=True) is None  # unless needed


def test_lookout_refuses_a_room_with_no_open_place():
    floor, room = _room_with_a_cupboard()
    assert floor.lookout(room, [(1.0, 1.5)], clearance=2.0) is None
    assert floor.lookout(room, [], clearance=0.45) is None
    assert floor.lookout([[10.0, 10.0], [11.0, 10.0], [11.0, 11.0]], [(1.0, 1.5)]) is None  # off the map


def test_lookouts_of_the_apartment_are_in_their_rooms_and_open():
    from map_server.mapfile import load_map

    grid = load_map(map_file("apartment", "apartment.yaml"))
    floor = FloorMap(grid.data, grid.origin, grid.resolution)
    rooms = Rooms.load(map_file("apartment", "rooms.yaml"))
    for label, spot in rooms.hotspots.items():
        look = floor.lookout(rooms.polygons[label], [(spot.x, spot.y)])
        assert rooms.room_at(look.x, look.y) == label and floor.problem(look.x, look.y, 0.45) is None, label
        assert math.hypot(look.x - spot.x, look.y - spot.y) > 1.3, label  # the Kinect sees a seated person there


def _room_with_a_table():
    """A free 6 x 4 m room at 5 cm (walls all round) and, on a keep-out grid of its own (0.1 m cells),
    a table at x 2.5 .. 3.5, y 1.0 .. 3.0 that the laser's map does not have."""
    data = np.zeros((80, 120), dtype=int)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    keep = np.zeros((40, 60), dtype=int)
    keep[10:30, 25:35] = 100
    return (FloorMap(data, (0.0, 0.0, 0.0), 0.05), Grid(keep, (0.0, 0.0, 0.0), 0.1),
            [[0.0, 0.0], [6.0, 0.0], [6.0, 4.0], [0.0, 4.0]])


def test_unseen_lookout_sees_what_the_table_hid_from_the_first_place():
    floor, table, room = _room_with_a_table()
    first = (1.0, 2.0)  # west of the table: the floor east of it, behind it, is hidden
    behind = np.array([[4.2, 2.0], [4.5, 1.6], [4.5, 2.4]])
    sight = floor.with_obstacles(table)
    assert not sight.sight_matrix([first], behind, skip_end=0.35).any()
    spot = floor.unseen_lookout(room, [first], near=1.3, far=4.0, clearance=0.45, occluders=table)
    assert spot is not None and sight.problem(spot.x, spot.y, 0.45) is None  # not under the table either
    assert sight.sight_matrix([(spot.x, spot.y)], behind, skip_end=0.35).all()
    d = np.hypot(*(behind - (spot.x, spot.y)).T)
    assert (d >= 1.3).all() and (d <= 4.0).all()
    # facing the middle of the floor it newly sees: east of the table, more or less
    assert abs(math.remainder(spot.phi - math.atan2(2.0 - spot.y, 4.5 - spot.x), math.tau)) < math.radians(60)
    # without the table the first place saw behind it: the second place goes elsewhere
    walls = floor.unseen_lookout(room, [first], near=1.3, far=4.0, clearance=0.45)
    assert walls is not None and (walls.x, walls.y) != (spot.x, spot.y)


def test_unseen_lookout_gives_none_when_no_place_sees_enough_new_floor():
    floor, table, room = _room_with_a_table()
    assert floor.unseen_lookout(room, [(1.0, 2.0)], occluders=table, min_gain=100.0) is None
    assert floor.unseen_lookout(room, [], occluders=table) is None
    assert floor.unseen_lookout(room, [(1.0, 2.0)], clearance=3.0) is None  # no open place
    assert floor.unseen_lookout([[10.0, 10.0], [11.0, 10.0], [11.0, 11.0]], [(1.0, 2.0)]) is None  # off the map


def test_unseen_lookouts_of_the_apartment_see_more_of_the_living_room_than_the_reach_rule():
    """Over the hotspot and 7 random first places of the living room, what two places see of the
    floor (0.1 m cells, a person's radius from the walls; the Kinect's 1.3-4 m, the keep-out map's
    tables and chairs hiding): the unseen_lookout's second place sees more than lookout's (measured
    29 Nov: 0.80 against 0.76 on average here; bench probe with a third place: 0.93 against 0.83)."""
    from map_server.mapfile import load_map

    grid, keep = (load_map(map_file("apartment", name)) for name in ("apartment.yaml", "apartment_keepout.yaml"))
    floor = FloorMap(grid.data, grid.origin, grid.resolution)
    table = Grid(keep.data, keep.origin, keep.resolution)
    sight = floor.with_obstacles(table)
    room = Rooms.load(map_file("apartment", "rooms.yaml"))
    poly = np.asarray(room.polygons["living_room"])
    xs, ys = np.meshgrid(np.arange(0.05, 5.0, 0.1), np.arange(0.05, 5.5, 0.1))
    cells = np.column_stack([xs.ravel(), ys.ravel()])
    cells = cells[floor.clearance_at(cells) >= 0.2]

    def seen(spots):
        d = np.hypot(*(np.asarray(spots)[:, None, :] - cells[None, :, :]).transpose(2, 0, 1))
        return (sight.sight_matrix(spots, cells, skip_end=0.35, max_length=4.0) & (d >= 1.3)).any(axis=0).mean()

    rng = np.random.default_rng(1)
    firsts = [(room.hotspots["living_room"].x, room.hotspots["living_room"].y)]
    while len(firsts) < 8:
        p = rng.uniform((0.0, 0.0), (5.0, 5.5))
        if contains_points(poly, p[None])[0] and sight.clearance_at(p[None])[0] >= 0.45:
            firsts.append(tuple(p))
    old, new = [], []
    for first in firsts:
        a = floor.lookout(poly, [first])
        b = floor.unseen_lookout(poly, [first], occluders=table)
        old.append(seen([first, (a.x, a.y)]))
        new.append(seen([first, (b.x, b.y)]))
    assert np.mean(new) > np.mean(old) + 0.02, (np.mean(new), np.mean(old))


def test_unseen_lookout_of_a_hall_is_coarser_not_slower():
    """A 30 x 30 m hall at 0.1 m (no walls inside): the grid of the floor is coarsened to at most
    MAX_LOOKOUT_CELLS cells (the place chosen is one of its cells), so the answer comes in about
    the time of a room's, not in minutes."""
    from florence_locator.places import MAX_LOOKOUT_CELLS

    data = np.zeros((300, 300), dtype=int)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    floor = FloorMap(data, (0.0, 0.0, 0.0), 0.1)
    hall = [[0.0, 0.0], [30.0, 0.0], [30.0, 30.0], [0.0, 30.0]]
    spot = floor.unseen_lookout(hall, [(5.0, 5.0)])
    assert spot is not None and floor.problem(spot.x, spot.y, 0.45) is None
    assert 1.3 <= math.hypot(spot.x - 5.0, spot.y - 5.0) <= 8.0 + 1e-9  # it sees floor the first turn did not
    step = math.sqrt(900.0 / MAX_LOOKOUT_CELLS)  # 0.67 m
    for v in (spot.x, spot.y):
        k = (v - step / 2) / step
        assert k == pytest.approx(round(k), abs=1e-6)
