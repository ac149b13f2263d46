"""SupportSurface: validation, point-in-polygon, goal band and its sampling."""

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from slideplan import _core
from slideplan.errors import InputError
from slideplan.world.geometry import Ending, SupportSurface, area_centroid, support_margin

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



def test_the_core_accepts_every_fine_table_shapely_accepts_and_both_bound_the_vertex_count():
    # A 1 cm circle of the most vertices: the core once called its 3 micrometre edges' turns collinear.
    limit = _core.SupportSurface.MAX_VERTICES
    fine = SupportSurface.circle((0.5, 0.0), 0.005, points=limit)
    assert _core.SupportSurface(fine.vertices, 0.0).area == pytest.approx(fine.area)
    vertices = np.vstack([fine.vertices, [[0.5 + 0.006, 0.0]]])
    with pytest.raises(InputError, match=f"table.polygon: polygon has {limit + 1} vertices, at most {limit}"):
        SupportSurface.from_vertices(vertices, field="table.polygon")
    with pytest.raises(ValueError, match=f"at most {limit}"):
        _core.SupportSurface(vertices, 0.0)


def test_ending_is_the_overhang_and_centre_of_mass_margin_and_graspable_needs_both():
    table = SupportSurface.from_vertices(SQUARE)
    # A 10 cm square whose right 3 cm overhang the x = 0.85 edge; its centre 2 cm inside it.
    xs, ys = np.meshgrid(np.linspace(0.78, 0.88, 11), np.linspace(-0.05, 0.05, 11))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    end = Ending.at(table, points, (0.83, 0.0))
    assert end.overhang == pytest.approx(0.03) and end.com_margin == pytest.approx(0.02)
    assert end.graspable(0.03 - 1e-9, 0.02 - 1e-9)
    assert not end.graspable(0.031, 0.0) and not end.graspable(0.0, 0.021)  # either one short is not graspable
    assert end.overhangs(0.031, slack=0.002) and end.com_inside(0.021, slack=0.002)  # the verifier's tolerance
    off = Ending.at(table, points + [0.05, 0.0], (0.88, 0.0))
    assert off.com_margin == pytest.approx(-0.03) and not off.graspable(0.0, 0.0)
    assert Ending.at(table, points - [0.1, 0.0], (0.73, 0.0)).overhang == 0.0


def test_the_support_margin_is_the_centre_of_mass_inside_what_the_table_bears():
    """support_hull: an L whose 2 cm foot lies beyond the x = 0.85 edge and whose 2 cm stem runs back along the
    table. Its centre of mass lies 1.8 cm inside the table, yet off the part the table bears (the stem): the L
    tips over the edge once the finger lets go."""
    table = SupportSurface.from_vertices(SQUARE)
    xs, ys = np.meshgrid(np.linspace(0.74, 0.88, 71), np.linspace(-0.05, 0.05, 51))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    points = grid[(grid[:, 0] >= 0.86 - 1e-9) | (grid[:, 1] <= -0.03 + 1e-9)]  # the foot and the stem
    com = area_centroid(points)
    end = Ending.at(table, points, com)
    assert end.com_margin == pytest.approx(0.85 - com[0]) and end.com_margin > 0.015 and end.graspable(0.02, 0.005)
    assert -0.03 < com[1] < -0.015  # above the stem, whose part on the table spans y in [-0.05, -0.03]
    assert support_margin(table, points, com) == pytest.approx(-(com[1] + 0.03), abs=1e-9)
    # Where the part on the table surrounds the centre of mass, it reaches the table's edge (to the grid's 2 mm).
    assert support_margin(table, grid, (0.85 - 0.02, 0.0)) == pytest.approx(0.02, abs=0.0021)
    # Wholly off the table, nothing bears it.
    assert support_margin(table, grid + [1.0, 0.0], (1.83, 0.0)) == -math.inf
