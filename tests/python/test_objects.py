"""Thin objects: built-in outlines, sampling, poses, point-cloud loaders, random poses."""

import math

import numpy as np
import plyfile
import pytest
import shapely
from shapely.geometry import Polygon

from slideplan.errors import InputError
from slideplan.world.geometry import SupportSurface
from slideplan.world.objects import (
    ThinObject,
    load_object,
    load_outline,
    load_point_cloud,
    place_outline,
    sample_pose_on_table,
)
from slideplan.paths import builtin_objects, builtin_scenes
from slideplan.world.scenes import load_scene

BUILTIN_OBJECTS = ["square", "circle", "triangle", "crescent", "irregular", "Y", "A", "L", "E"]


def test_builtin_object_list_is_complete():
    assert sorted(builtin_objects()) == sorted(BUILTIN_OBJECTS)


@pytest.mark.parametrize("name", BUILTIN_OBJECTS)
def test_builtin_outline_is_palm_sized_and_centred(name):
    outline, thickness, loaded_name = load_outline(name)
    assert loaded_name == name
    assert thickness == 0.004
    assert outline.is_valid
    min_x, min_y, max_x, max_y = outline.bounds
    assert 0.06 <= max(max_x - min_x, max_y - min_y) <= 0.13
    assert math.hypot(outline.centroid.x, outline.centroid.y) < 1e-4


def test_builtin_names_are_case_sensitive():
    with pytest.raises(InputError, match="built-in"):
        load_outline("a")


def test_circle_has_48_vertices_and_a_has_a_hole():
    assert len(load_outline("circle")[0].exterior.coords) - 1 == 48
    assert len(load_outline("A")[0].interiors) == 1


@pytest.mark.parametrize("scene_name", ["square", "round", "triangle", "long"])
@pytest.mark.parametrize("name", BUILTIN_OBJECTS)
def test_builtin_object_at_table_centroid_lies_on_table(scene_name, name):
    table = load_scene(scene_name).table
    centre = table.polygon.centroid
    thin_object = load_object(name, table_height=table.height, pose=(centre.x, centre.y, 0.3))
    assert table.polygon.contains(thin_object.outline)
    assert table.contains(thin_object.points[:, :2]).all()
    np.testing.assert_allclose(thin_object.points[:, 2], table.height + 0.004)


def test_from_outline_applies_pose_and_samples_grid_and_boundary():
    square = Polygon([(-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05)])
    thin_object = ThinObject.from_outline(
        square, thickness=0.003, table_height=0.5, pose=(1.0, 2.0, math.pi / 4), resolution=0.01, name="sq"
    )
    np.testing.assert_allclose(thin_object.centroid_xy, [1.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(thin_object.points[:, 2], 0.503)
    radii = np.hypot(thin_object.points[:, 0] - 1.0, thin_object.points[:, 1] - 2.0)
    assert radii.max() == pytest.approx(0.05 * math.sqrt(2))  # the corners are sampled
    # Corner (0.05, 0.05) rotated by 45 degrees lands straight above the centre.
    assert np.any(np.all(np.isclose(thin_object.points[:, :2], [1.0, 2.0 + 0.05 * math.sqrt(2)]), axis=1))
    assert thin_object.outline.equals(place_outline(square, (1.0, 2.0, math.pi / 4)))
    assert len(thin_object.points) == 9 * 9 + 40  # interior grid + boundary every 1 cm
    assert not thin_object.points.flags.writeable


def test_from_outline_respects_holes():
    outline, thickness, _ = load_outline("A")
    thin_object = ThinObject.from_outline(outline, thickness=thickness, table_height=0.0, pose=(0, 0, 0), resolution=0.002)
    # Shrink the hole a little: points sampled on its edge may round to either side.
    hole = Polygon(outline.interiors[0]).buffer(-1e-9)
    assert not shapely.contains_xy(hole, thin_object.points[:, 0], thin_object.points[:, 1]).any()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"thickness": 0.0}, "thickness"),
        ({"resolution": -0.01}, "resolution"),
        ({"resolution": 1e-7}, "resolution"),
        ({"pose": (0.0, float("nan"), 0.0)}, "pose"),
        ({"pose": (0.0, 0.0)}, "pose"),
    ],
)
def test_from_outline_rejects_bad_arguments(kwargs, field):
    arguments = {"thickness": 0.004, "table_height": 0.0, "pose": (0.0, 0.0, 0.0), "resolution": 0.005} | kwargs
    with pytest.raises(InputError, match=field):
        ThinObject.from_outline(load_outline("square")[0], **arguments)


def test_from_outline_rejects_invalid_polygon():
    bow_tie = Polygon([(0, 0), (1, 1), (1, 0), (0, 1)])
    with pytest.raises(InputError, match="outline"):
        ThinObject.from_outline(bow_tie, thickness=0.004, table_height=0.0, pose=(0, 0, 0))


def test_scale_halves_outline_but_not_thickness():
    full = load_object("L", table_height=0.0, pose=(0.5, 0.0, 0.0))
    half = load_object("L", table_height=0.0, pose=(0.5, 0.0, 0.0), scale=0.5)
    assert half.outline.area == pytest.approx(full.outline.area / 4)
    assert half.thickness == full.thickness


def test_outline_object_requires_pose():
    with pytest.raises(InputError, match="pose"):
        load_object("square", table_height=0.0)


def test_from_points_thickness_is_mean_height_above_table():
    points = np.array([[0, 0, 0.105], [1, 0, 0.104], [0, 1, 0.103]])
    thin_object = ThinObject.from_points(points, table_height=0.1, name="cloud")
    assert thin_object.thickness == pytest.approx(0.004)
    assert thin_object.outline is None
    np.testing.assert_allclose(thin_object.centroid_xy, [1 / 3, 1 / 3])


def test_from_points_below_table_raises():
    with pytest.raises(InputError, match="below the table top"):
        ThinObject.from_points(np.zeros((5, 3)), table_height=0.0, source="c.npy")


CLOUD = np.array([[0.5, 0.0, 0.004], [0.6, 0.01, 0.004], [0.55, 0.1, 0.0041], [0.52, -0.03, 0.0039]])


def write_ply(path, points, *, text):
    vertex = np.array([tuple(point) for point in points], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex")], text=text).write(str(path))


def write_pcd(path, cloud, binary):
    """A PCL .pcd file with doubles x, y, z and a float intensity, so the reader must pick x, y, z out."""
    header = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 8 8 8 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
              f"WIDTH {len(cloud)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(cloud)}\nDATA {'binary' if binary else 'ascii'}\n")
    rows = np.zeros(len(cloud), dtype=[("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("intensity", "<f4")])
    rows["x"], rows["y"], rows["z"], rows["intensity"] = *cloud.T, 7.0
    body = rows.tobytes() if binary else "".join(f"{x!r} {y!r} {z!r} 7\n" for x, y, z in cloud.tolist()).encode()
    path.write_bytes(header.encode() + body)


WRITERS = {
    "cloud.npy": lambda path: np.save(path, CLOUD),
    "plain.csv": lambda path: np.savetxt(path, CLOUD, delimiter=","),
    "header.csv": lambda path: np.savetxt(path, CLOUD, delimiter=",", header="x,y,z", comments=""),
    "ascii.ply": lambda path: write_ply(path, CLOUD, text=True),
    "binary.ply": lambda path: write_ply(path, CLOUD, text=False),
    "ascii.pcd": lambda path: write_pcd(path, CLOUD, binary=False),
    "binary.pcd": lambda path: write_pcd(path, CLOUD, binary=True),
}


@pytest.mark.parametrize("file_name", list(WRITERS))
def test_cloud_loaders_round_trip(tmp_path, file_name):
    path = tmp_path / file_name
    WRITERS[file_name](path)
    np.testing.assert_allclose(load_point_cloud(path), CLOUD, rtol=0, atol=1e-15)


def test_binary_ply_is_really_binary(tmp_path):
    path = tmp_path / "binary.ply"
    write_ply(path, CLOUD, text=False)
    assert b"format binary" in path.read_bytes()[:100]


def test_cloud_object_is_used_where_it_lies(tmp_path):
    path = tmp_path / "card.npy"
    np.save(path, CLOUD)
    thin_object = load_object(path, table_height=0.0)
    np.testing.assert_array_equal(thin_object.points, CLOUD)
    assert thin_object.thickness == pytest.approx(0.004)
    assert thin_object.name == "card"
    with pytest.raises(InputError, match="pose"):
        load_object(path, table_height=0.0, pose=(0, 0, 0))


BAD_CLOUDS = {
    "empty.csv": (lambda path: path.write_text(""), "empty"),
    "header_only.csv": (lambda path: path.write_text("x,y,z\n"), "empty"),
    "nan.npy": (lambda path: np.save(path, np.array([[0, 0, 1], [0, np.nan, 1], [1, 1, 1]])), "NaN"),
    "inf.csv": (lambda path: path.write_text("0,0,1\n1,0,inf\n0,1,1\n"), "NaN or inf"),
    "two_columns.npy": (lambda path: np.save(path, np.zeros((5, 2))), "shape"),
    "complex.npy": (lambda path: np.save(path, np.eye(3) + 1j), "complex"),  # once read with the imaginary parts dropped
    "ragged.csv": (lambda path: path.write_text("0,0,1\n1,0\n"), "cannot read"),
    "two_points.csv": (lambda path: path.write_text("0,0,1\n1,0,1\n"), "at least 3"),
    "no_z.ply": (lambda path: plyfile.PlyData(
        [plyfile.PlyElement.describe(np.zeros(3, dtype=[("x", "f4"), ("y", "f4")]), "vertex")]
    ).write(str(path)), "vertex.z"),
    "garbage.ply": (lambda path: path.write_bytes(b"not a ply file"), "cannot read"),
    "compressed.pcd": (lambda path: path.write_bytes(b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 3\nDATA binary_compressed\n"),
                       "binary_compressed is not supported"),
    "no_z.pcd": (lambda path: path.write_text("FIELDS x y\nSIZE 4 4\nTYPE F F\nPOINTS 1\nDATA ascii\n0 0\n"), "lack x, y or z"),
    "cloud.txt": (lambda path: path.write_text("0,0,1\n"), "unsupported"),
    "missing.npy": (lambda path: None, "not found"),
}


@pytest.mark.parametrize("file_name", list(BAD_CLOUDS))
def test_bad_clouds_raise_input_error_naming_the_file(tmp_path, file_name):
    write, problem = BAD_CLOUDS[file_name]
    path = tmp_path / file_name
    write(path)
    with pytest.raises(InputError) as raised:
        load_point_cloud(path)
    assert str(raised.value).startswith(str(path))
    assert problem in str(raised.value)


def test_outline_toml_with_hole_and_defaults(tmp_path):
    path = tmp_path / "frame.toml"
    path.write_text(
        "outline = [[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]]\n"
        "holes = [[[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]]\n"
    )
    outline, thickness, name = load_outline(path)
    assert outline.area == pytest.approx(0.01 - 0.0016)
    assert thickness == 0.004
    assert name == "frame"


@pytest.mark.parametrize(
    ("text", "field", "problem"),
    [
        ("thickness = 0.004\n", "outline", "missing"),
        ('outline = "square"\n', "outline", "list"),
        ("outline = [[0, 0], [1, 0], [0, 1]]\nthickness = \"thin\"\n", "thickness", "number"),
        ("outline = [[0, 0], [1, 0], [0, 1]]\nthickness = -1.0\n", "thickness", "> 0"),
        ("outline = [[0, 0], [1, 0], [0]]\n", "outline[2]", "2 numbers"),
        ("outline = [[0, 0], [1, 1], [1, 0], [0, 1]]\n", "outline", "self-intersecting"),
        ("outline = [[0, 0], [1, 0], [0, 1]]\nholes = [[[2, 2], [3, 2], [2, 3]]]\n", "holes", "inside"),
        ("outline = [[0, 0], [1, 0], [0, 1]]\nthicknes = 0.004\n", "thicknes", "unknown field"),
        ("outline = [[0, 0], [1, 0], [0, 1]\n", "", "invalid TOML"),
    ],
)
def test_bad_outline_toml_names_file_and_field(tmp_path, text, field, problem):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError) as raised:
        load_outline(path)
    assert str(raised.value).startswith(f"{path}: {field}")
    assert problem in str(raised.value)


def test_an_outline_too_large_to_sample_names_its_file_and_size(tmp_path):
    # Once "resolution: resolution 0.005 m would give about 1.6e+09 points", naming no file (millimetres?).
    path = tmp_path / "tray.toml"
    path.write_text("thickness = 0.004\noutline = [[-100, -100], [100, -100], [100, 100], [-100, 100]]\n")
    with pytest.raises(InputError, match=r"the outline \(200 x 200 m\) sampled every 0.005 m .* is it in metres") as raised:
        load_object(path, table_height=0.0, pose=(0, 0, 0))
    assert raised.value.source == str(path) and raised.value.field == "resolution"


def test_unknown_object_raises():
    with pytest.raises(InputError, match="no such file"):
        load_object("no_such_object", table_height=0.0, pose=(0, 0, 0))


def test_sample_pose_on_table_is_seeded_and_on_table():
    table = load_scene("triangle").table
    outline = load_outline("crescent")[0]
    poses = [sample_pose_on_table(outline, table, np.random.default_rng(seed)) for seed in (1, 1, 2)]
    assert poses[0] == poses[1]
    assert poses[0] != poses[2]
    for pose in poses:
        assert -math.pi <= pose[2] < math.pi
        assert table.polygon.contains(place_outline(outline, pose))


def test_sample_pose_on_table_keeps_margin():
    table = load_scene("square").table
    outline = load_outline("E")[0]
    rng = np.random.default_rng(5)
    for _ in range(20):
        posed = place_outline(outline, sample_pose_on_table(outline, table, rng, margin=0.05))
        assert table.polygon.exterior.distance(posed) >= 0.05 - 1e-12
        assert table.polygon.contains(posed)


def test_sample_pose_on_table_object_larger_than_table_raises():
    table = SupportSurface.from_vertices([[0, 0], [0.1, 0], [0.1, 0.1], [0, 0.1]])
    big = Polygon([(-0.2, -0.2), (0.2, -0.2), (0.2, 0.2), (-0.2, 0.2)])
    with pytest.raises(InputError, match="larger than the table"):
        sample_pose_on_table(big, table, np.random.default_rng(0))


def test_sample_pose_on_table_gives_up_when_object_does_not_fit():
    # Smaller in area than the table but too long for it in every orientation.
    table = SupportSurface.from_vertices([[0, 0], [0.3, 0], [0.3, 0.3], [0, 0.3]])
    stick = Polygon([(-0.3, -0.01), (0.3, -0.01), (0.3, 0.01), (-0.3, 0.01)])
    with pytest.raises(InputError, match="no pose"):
        sample_pose_on_table(stick, table, np.random.default_rng(0), max_tries=200)


def test_every_builtin_scene_has_a_random_pose_for_every_object():
    rng = np.random.default_rng(11)
    for scene_name in builtin_scenes():
        table = load_scene(scene_name).table
        for name in BUILTIN_OBJECTS:
            outline = load_outline(name)[0]
            assert table.polygon.contains(place_outline(outline, sample_pose_on_table(outline, table, rng)))


@pytest.mark.parametrize("name, turns", [("circle", 360), ("square", 4), ("triangle", 3), ("crescent", 1), ("L", 1)])
def test_an_objects_symmetry_turns_are_the_turns_that_leave_its_footprint(name, turns):
    obj = load_object(name, table_height=0.7, pose=(0.5, 0.1, 0.3))
    found = np.degrees(obj.symmetry_turns)
    assert len(found) == turns and found[0] == 0.0
    assert np.allclose(np.diff(found), 360.0 / turns)
    # Each turn about the centre of mass leaves the outline where it was; half way between two, it moves.
    centre = shapely.Point(obj.centroid_xy)
    for turn in found:
        assert shapely.affinity.rotate(obj.outline, turn, origin=centre).hausdorff_distance(obj.outline) < 5e-4
    if turns > 1 and turns < 360:
        assert shapely.affinity.rotate(obj.outline, 180.0 / turns, origin=centre).hausdorff_distance(obj.outline) > 5e-3
