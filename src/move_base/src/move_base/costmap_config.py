"""costmap_2d's parameters (pre-Hydro flat layout, as the seed's YAML files use them) and the
:class:`move_base.layers.LayeredCostmap` they describe (ROS-free).

The node reads them below ``~global_costmap/`` and ``~local_costmap/``
(:class:`move_base.costmap_ros.Costmap2DROS`); ``bench/nav_plan.py`` builds the same costmap
from the shipped launch file's values, so the planner is timed on what the product plans on.

    cfg = CostmapConfig.read(lambda key, default: values.get(key, default))
    layered = cfg.layered()
"""

from dataclasses import dataclass

import numpy as np

from florence_common.params import FRAME, Param, ParamError, Params, ParamTable
from move_base.footprint import footprint_value, pad_footprint, parse_footprint
from move_base.layers import LayeredCostmap, ObservationSource
from move_base.people_layer import PROXEMIC_PARAMS
from move_base.voxel_layer import MAX_Z_VOXELS

DATA_TYPES = ("LaserScan", "PointCloud", "PointCloud2")
MAP_TYPES = ("costmap", "voxel")

BODY_PADDING = 0.01  # [m] the seed's footprint_padding: the Create's round body (0.1696 m) fills the footprint's
# sides (0.16 m) with it; a larger footprint_padding is a margin the robot may use to leave a tight spot


def _named(frame):
    return "must name a frame" if not frame else None


def _footprint_problem(value):
    try:
        parse_footprint(value, 1.0)
    except ValueError as exc:
        return str(exc)
    return None


PARAMS = ParamTable(
    Param("global_frame", FRAME, "/map", "frame of the grid (a leading '/' is dropped: tf2 refuses it)",
          check=_named),
    Param("robot_base_frame", FRAME, "base_link", "the robot's frame", check=_named),
    Param("transform_tolerance", float, 0.3, "oldest robot pose accepted", unit="s", ge=0.0),
    Param("update_frequency", float, 5.0, "update-loop rate (0: no loop, updates on request only)", unit="Hz",
          ge=0.0),
    Param("publish_frequency", float, 0.0, "rate of the published OccupancyGrid (0: never)", unit="Hz", ge=0.0),
    Param("static_map", bool, True, "use the map on map_topic (a global costmap takes its geometry; a rolling "
          "window in another frame places it through tf at each update)"),
    Param("rolling_window", bool, False, "the grid follows the robot"),
    Param("width", float, 10.0, "grid width (without a static map, or with a rolling window)", unit="m", gt=0.0),
    Param("height", float, 10.0, "grid height", unit="m", gt=0.0),
    Param("resolution", float, 0.05, "cell side", unit="m", gt=0.0),
    Param("origin_x", float, 0.0, "x of the grid's corner", unit="m"),
    Param("origin_y", float, 0.0, "y of the grid's corner", unit="m"),
    Param("map_topic", str, "map", "the static map's topic"),
    Param("track_unknown_space", bool, False, "keep unknown cells NO_INFORMATION (else free)"),
    Param("lethal_cost_threshold", int, 100, "map value from which a cell is lethal", gt=0, le=100),
    Param("obstacle_range", float, 2.5, "farthest reading that marks (sources' default)", unit="m", ge=0.0),
    Param("raytrace_range", float, 3.0, "farthest a ray clears (sources' default)", unit="m", ge=0.0),
    Param("max_obstacle_height", float, 2.0, "highest reading kept (sources' default)", unit="m"),
    Param("footprint", list, None, "the robot's outline, [[x, y], ...] in the base frame, or its string form "
          "(unset: a circle of robot_radius)", unit="m", optional=True, check=_footprint_problem),
    Param("robot_radius", float, 0.46, "radius of a round robot, when there is no footprint", unit="m", gt=0.0),
    Param("footprint_padding", float, 0.01, "added to the footprint's coordinates, away from the centre", unit="m",
          ge=0.0),
    Param("inflation_radius", float, 0.55, "how far lethal cells are inflated", unit="m", ge=0.0),
    Param("cost_scaling_factor", float, 10.0, "decay of the inflated cost with distance", unit="1/m", ge=0.0),
    Param("observation_sources", str, "", "space-separated names of the sensor sources, each a dictionary of "
          "SOURCE_PARAMS in the costmap's namespace"),
    Param("map_type", str, "costmap", "the obstacle layer: 'costmap' (2-D) or 'voxel' (3-D columns: what one "
          "sensor sees at one height is not cleared by another's ray at another)", choices=MAP_TYPES),
    Param("origin_z", float, 0.0, "voxel: bottom of the columns", unit="m"),
    Param("z_resolution", float, 0.2, "voxel: height of a voxel", unit="m", gt=0.0),
    Param("z_voxels", int, 10, "voxel: voxels per column", ge=1, le=MAX_Z_VOXELS),
    Param("mark_threshold", int, 0, "voxel: marked voxels a column may hold and still be free", ge=0),
    Param("publish_voxel_map", bool, False, "voxel: publish the marked voxels' centres on ~<costmap>/voxel_grid "
          "(sensor_msgs/PointCloud2; ROS: costmap_2d/VoxelGrid)"),
    Param("keepout_map_topic", str, "", "Florence: a keep-out map (nav_msgs/OccupancyGrid, map_server's format): "
          "its occupied cells are lethal, before the inflation ('': none)"),
    Param("people_topic", str, "", "Florence: the tracked people (user_tracker_ni/TrackedUsers) of a proxemic "
          "layer, PROXEMIC_PARAMS in ~<costmap>/proxemic/ ('': none)"),
)
"""A costmap's parameters (``~global_costmap/``, ``~local_costmap/``: costmap_2d's names and defaults)."""

SOURCE_PARAMS = ParamTable(
    Param("topic", str, "", "topic of the readings ('': the source's name)"),
    Param("sensor_frame", FRAME, "", "frame whose origin rays start from ('': the reading's frame)"),
    Param("data_type", str, "PointCloud", "message type of the topic", choices=DATA_TYPES),
    Param("marking", bool, True, "readings mark obstacles"),
    Param("clearing", bool, False, "rays clear free space"),
    Param("observation_persistence", float, 0.0, "how long a reading is kept (0: the newest only)", unit="s",
          ge=0.0),
    Param("expected_update_rate", float, 0.0, "longest time between readings before the source is stale "
          "(0: not checked)", unit="s", ge=0.0),
    Param("min_obstacle_height", float, 0.0, "lowest reading kept", unit="m"),
    Param("max_obstacle_height", float, None, "highest reading kept (unset: the costmap's)", unit="m",
          optional=True),
    Param("obstacle_range", float, None, "farthest reading that marks (unset: the costmap's)", unit="m", ge=0.0,
          optional=True),
    Param("raytrace_range", float, None, "farthest a ray clears (unset: the costmap's)", unit="m", ge=0.0,
          optional=True),
    Param("inf_is_valid", bool, False, "LaserScan: +inf is a ray with no return (clears), not a bad reading"),
)
"""One observation source of a costmap (``~<costmap>/<source>/``: costmap_2d's names and defaults)."""


@dataclass(frozen=True)
class SourceInput:
    """Where an observation source's readings come from."""

    topic: str
    sensor_frame: str  # '' = the reading's own frame
    data_type: str  # one of DATA_TYPES
    inf_is_valid: bool


@dataclass(frozen=True)
class CostmapConfig:
    """A costmap's validated parameters, its padded footprint (N, 2) [m] and its observation
    sources (the obstacle layer's :class:`ObservationSource` and where each one's readings come from)."""

    params: Params
    footprint: np.ndarray
    sources: tuple
    inputs: dict
    proxemic: Params | None = None

    @property
    def body(self):
        """The robot's own outline (N, 2) [m]: the footprint padded by at most BODY_PADDING."""
        return pad_footprint(parse_footprint(self.params.footprint, self.params.robot_radius),
                             min(self.params.footprint_padding, BODY_PADDING))

    @classmethod
    def read(cls, get):
        """The configuration from ``get(key, default)``, a getter of the costmap's namespace (each
        source is one dictionary ``get(source, {})``). Raises ParamError naming every bad parameter."""

        def get_param(key, default):
            value = get(key, default)
            return footprint_value(value) if key == "footprint" and isinstance(value, str) else value

        try:
            p = PARAMS.read(get_param)
        except ValueError as exc:  # a footprint string that is not YAML
            raise ParamError(str(exc)) from None
        footprint = pad_footprint(parse_footprint(p.footprint, p.robot_radius), p.footprint_padding)
        sources, inputs = [], {}
        for name in p.observation_sources.split():
            cfg = get(name, {})
            if not isinstance(cfg, dict):
                raise ParamError(f"~{name} (an observation source) must be a dictionary, got {cfg!r}")
            try:
                s = SOURCE_PARAMS.read(lambda key, default, cfg=cfg: cfg.get(key, default))
            except ParamError as exc:
                raise ParamError(f"observation source ~{name}: {exc}") from None
            sources.append(ObservationSource(
                name=name,
                obstacle_range=p.obstacle_range if s.obstacle_range is None else s.obstacle_range,
                raytrace_range=p.raytrace_range if s.raytrace_range is None else s.raytrace_range,
                min_obstacle_height=s.min_obstacle_height,
                max_obstacle_height=p.max_obstacle_height if s.max_obstacle_height is None else s.max_obstacle_height,
                marking=s.marking,
                clearing=s.clearing,
                observation_persistence=s.observation_persistence,
                expected_update_rate=s.expected_update_rate,
            ))
            inputs[name] = SourceInput(s.topic or name, s.sensor_frame, s.data_type, s.inf_is_valid)
        proxemic = None
        if p.people_topic:
            cfg = get("proxemic", {})
            if not isinstance(cfg, dict):
                raise ParamError(f"~proxemic must be a dictionary of the proxemic layer's parameters, got {cfg!r}")
            try:
                proxemic = PROXEMIC_PARAMS.read(cfg.get)
            except ParamError as exc:
                raise ParamError(f"~proxemic: {exc}") from None
        return cls(p, footprint, tuple(sources), inputs, proxemic)

    @property
    def size(self):
        """(size_x, size_y) [cells] of the grid before a static map gives it its own."""
        p = self.params
        return max(1, int(p.width / p.resolution)), max(1, int(p.height / p.resolution))

    def layered(self, now=0.0):
        """A new :class:`LayeredCostmap` of this configuration; ``now`` [s] starts the sources' clocks."""
        p = self.params
        size_x, size_y = self.size
        return LayeredCostmap(
            size_x,
            size_y,
            p.resolution,
            p.origin_x,
            p.origin_y,
            footprint=self.footprint,
            rolling_window=p.rolling_window,
            track_unknown_space=p.track_unknown_space,
            static_map=p.static_map,
            sources=self.sources,
            inflation_radius=p.inflation_radius,
            cost_scaling_factor=p.cost_scaling_factor,
            lethal_cost_threshold=p.lethal_cost_threshold,
            now=now,
            voxel=({"origin_z": p.origin_z, "z_resolution": p.z_resolution, "z_voxels": p.z_voxels,
                    "mark_threshold": p.mark_threshold} if p.map_type == "voxel" else None),
            keepout=bool(p.keepout_map_topic),
            proxemic=None if self.proxemic is None else dict(self.proxemic),
        )
