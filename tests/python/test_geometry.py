"""SupportSurface: validation, point-in-polygon, goal band and its sampling."""

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from slideplan.errors import InputError
from slideplan.geometry import SupportSurface, sample_in_triangles, triangle_areas

SQUARE = [[0.35, -0.25], [0.85, -0.25], [0.85, 0.25], [0.35, 0.25]]
L_SHAPE = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.4], [0.4, 0.4], [0.4, 1.0], [0.0, 1.0]]


def make_table(shape: str) -> SupportSurface:
    if shape == "square":
        return SupportSurface.from_vertices(SQUARE)
    if shape == "round":
        return SupportSurface.circle((0.6, 0.0), 0.27, points=100)
    return SupportSurface.from_vertices(L_SHAPE)


SHAPES = ["square", "round", "L"]


@pytest.mark.parametrize(
    ("shape", "inside", "outside"),
    [
        ("square", [[0.6, 0.0], [0.36, 0.24], [0.84, -0.24]], [[0.3, 0.0], [0.86, 0.0], [0.6, 0.26]]),
        ("round", [[0.6, 0.0], [0.86, 0.0], [0.6, -0.265]], [[0.88, 0.0], [0.6, 0.28], [0.8, 0.2]]),
        ("L", [[0.2, 0.8], [0.7, 0.2], [0.2, 0.2]], [[0.7, 0.7], [0.5, 0.5], [1.1, 0.2]]),
    ],
)
def test_contains_known_points(shape, inside, outside):
    table = make_table(shape)
    assert table.contains(np.array(inside)).tolist() == [True] * len(inside)
    assert table.contains(np.array(outside)).tolist() == [False] * len(outside)


def test_contains_rejects_wrong_shape():
    with pytest.raises(InputError, match="xy"):
        make_table("square").contains(np.zeros((4, 3)))


def test_clockwise_input_is_normalised_to_counter_clockwise_without_closing_vertex():
    clockwise = SQUARE[::-1] + [SQUARE[-1]]  # closed ring, clockwise
    table = SupportSurface.from_vertices(clockwise, height=0.7)
    x, y = table.vertices[:, 0], table.vertices[:, 1]
    signed_area = 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    assert signed_area == pytest.approx(0.25)
    assert len(table.vertices) == 4
    assert table.height == 0.7
    assert Polygon(table.vertices).equals(Polygon(SQUARE))
    assert not table.vertices.flags.writeable


def test_counter_clockwise_input_is_kept_as_given():
    table = SupportSurface.from_vertices(SQUARE)
    np.testing.assert_array_equal(table.vertices, SQUARE)


@pytest.mark.parametrize(
    ("vertices", "problem"),
    [
        ([[0, 0], [1, 1], [1, 0], [0, 1]], "self-intersecting"),
        ([[0, 0], [1, 0]], "at least 3 vertices"),
        ([[0, 0], [1, float("nan")], [0, 1]], "finite"),
        ([[0, 0], [1, 0], [2, 0]], "degenerate"),
        ([[0, 0], [1, 0], [1, 1e-9]], "degenerate"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "shape"),
    ],
)
def test_bad_polygons_raise_input_error_naming_file_field_and_problem(vertices, problem):
    with pytest.raises(InputError) as raised:
        SupportSurface.from_vertices(vertices, source="scenes/x.toml", field="table.polygon")
    assert str(raised.value).startswith("scenes/x.toml: table.polygon: ")
    assert problem in str(raised.value)


def test_circle_has_requested_points_and_radius():
    table = SupportSurface.circle((0.6, 0.0), 0.27, points=100, height=0.1)
    assert table.vertices.shape == (100, 2)
    np.testing.assert_allclose(np.hypot(table.vertices[:, 0] - 0.6, table.vertices[:, 1]), 0.27)
    assert table.area == pytest.approx(0.5 * 100 * 0.27**2 * math.sin(2 * math.pi / 100))
    assert table.height == 0.1


@pytest.mark.parametrize(("radius", "points", "field"), [(0.0, 100, "radius"), (0.2, 2, "points")])
def test_circle_rejects_bad_arguments(radius, points, field):
    with pytest.raises(InputError, match=field):
        SupportSurface.circle((0.0, 0.0), radius, points=points)


def check_band_and_triangles(table: SupportSurface, d_goal: float) -> None:
    band = table.goal_band(d_goal)
    contracted = table.polygon.buffer(-d_goal, join_style="mitre")
    assert band.area == pytest.approx(table.area - contracted.area, rel=1e-9)
    triangles = table.goal_band_triangles(d_goal)
    assert triangles.ndim == 3 and triangles.shape[1:] == (3, 2)
    assert triangle_areas(triangles).sum() == pytest.approx(band.area, rel=1e-9)
    covered = shapely.union_all(shapely.polygons(triangles))
    assert covered.symmetric_difference(band).area <= 1e-9 * band.area


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("d_goal", [0.03, 0.1])
def test_goal_band_is_polygon_minus_contraction_and_triangles_cover_it_exactly(shape, d_goal):
    check_band_and_triangles(make_table(shape), d_goal)


@pytest.mark.parametrize("shape", SHAPES)
def test_fallback_triangulation_without_constrained_delaunay_is_exact(shape, monkeypatch):
    monkeypatch.delattr(shapely, "constrained_delaunay_triangles", raising=False)
    check_band_and_triangles(make_table(shape), 0.05)


def test_goal_band_is_whole_table_when_contraction_is_empty():
    narrow = SupportSurface.from_vertices([[0, 0], [1, 0], [1, 0.1], [0, 0.1]])
    assert narrow.goal_band(0.06).equals(narrow.polygon)
    assert triangle_areas(narrow.goal_band_triangles(0.06)).sum() == pytest.approx(0.1, rel=1e-9)


@pytest.mark.parametrize("d_goal", [0.0, -0.1, float("nan")])
def test_goal_band_rejects_bad_width(d_goal):
    with pytest.raises(InputError, match="d_goal"):
        make_table("square").goal_band(d_goal)


@pytest.mark.parametrize("shape", SHAPES)
def test_goal_band_samples_lie_in_band(shape):
    table = make_table(shape)
    d_goal = 0.05
    samples = table.sample_goal_band(3000, d_goal, np.random.default_rng(3))
    assert samples.shape == (3000, 2)
    band = table.goal_band(d_goal).buffer(1e-12)
    assert shapely.contains_xy(band, samples[:, 0], samples[:, 1]).all()
    assert shapely.contains_xy(table.polygon.buffer(1e-12), samples[:, 0], samples[:, 1]).all()


def test_goal_band_samples_are_uniform_by_area():
    table = make_table("square")
    d_goal = 0.05
    samples = table.sample_goal_band(40000, d_goal, np.random.default_rng(0))
    # The left strip x < 0.40 is 0.05 x 0.5 of the 0.09 m^2 band.
    expected = 0.025 / 0.09
    fraction = np.mean(samples[:, 0] < 0.35 + d_goal)
    assert fraction == pytest.approx(expected, abs=4 * math.sqrt(expected * (1 - expected) / 40000))


def test_goal_band_sampling_is_seeded():
    table = make_table("L")
    first = table.sample_goal_band(50, 0.1, np.random.default_rng(7))
    again = table.sample_goal_band(50, 0.1, np.random.default_rng(7))
    other = table.sample_goal_band(50, 0.1, np.random.default_rng(8))
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_sample_in_triangles_rejects_negative_count():
    triangles = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
    with pytest.raises(InputError, match="n"):
        sample_in_triangles(triangles, -1, np.random.default_rng(0))
