"""Outlines: validation errors, winding, the prism mesh and the analytic intersection."""

import numpy as np
import pytest

from mitnerf.errors import MitnerfError, Note
from mitnerf.scenes.polygon import Polygon
from mitnerf.scenes.registry import SCENES_2D, SCENES_XML

UNIT = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]


def test_named_outlines_are_valid_and_fit_the_views():
    for name in SCENES_2D:
        poly = Polygon.from_json(SCENES_XML / "polygons" / f"{name}.json")
        assert poly.signed_area() > 0                  # stored counter-clockwise
        assert poly.radius() < 1.7                     # inside the 53 degree view from radius 4
    assert len(Polygon.from_json(SCENES_XML / "polygons" / "bunny.json").points) >= 60


def test_clockwise_input_is_turned_counter_clockwise():
    poly = Polygon.from_points(UNIT[::-1])
    assert poly.signed_area() == pytest.approx(1.0)


@pytest.mark.parametrize("points, words", [
    ([[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]], "self-intersecting"),  # a bow tie
    ([[0, 0], [1, 0], [0, 0]], "at least 3"),
    ([[0, 0], [1, np.nan], [1, 1], [0, 0]], "NaN"),
    ([[0, 0], [1, 0], [2, 0], [0, 0]], "zero area"),
])
def test_bad_outlines_name_the_problem_and_the_fix(points, words):
    with pytest.raises(MitnerfError, match=words):
        Polygon.from_points(points)


def test_an_open_ring_is_closed_with_a_note():
    with pytest.warns(Note, match="was open"):
        poly = Polygon.from_points([[0, 0], [1, 0], [1, 1], [0, 1]])      # last point != first
    assert len(poly.points) == 4 and poly.signed_area() == pytest.approx(1.0)
    with pytest.raises(MitnerfError, match="self-intersecting"):               # closed, then checked like any
        Polygon.from_points([[0, 0], [1, 1], [1, 0], [0, 1]])


def test_intersection_of_the_unit_square_by_hand():
    poly = Polygon.from_points(UNIT)
    o = np.array([[-1.0, 0.5], [0.5, 0.5], [-1.0, 2.0], [2.0, 0.25]])
    d = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]])
    # from the left: wall x=0 at t=1; from inside: top wall at t=0.5; above: miss; from the right: x=1 at t=1
    np.testing.assert_allclose(poly.intersect(o, d), [1.0, 0.5, np.inf, 1.0])


def test_prism_walls_face_outward_and_caps_cover_the_outline():
    poly = Polygon.from_json(SCENES_XML / "polygons" / "square_concave.json")
    v, f, c = poly.prism(half_height=1.0)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    walls = np.abs(n[:, 2]) < 1e-9
    centre = tri[walls].mean(1)[:, :2]
    normal = n[walls][:, :2] / np.linalg.norm(n[walls][:, :2], axis=1, keepdims=True)
    # a step along the outward normal leaves the shape, a step inwards enters it
    assert not poly.contains(centre + 1e-3 * normal).any()
    assert poly.contains(centre - 1e-3 * normal).all()
    top = n[:, 2] > 1e-9
    assert 0.5 * n[top, 2].sum() == pytest.approx(poly.signed_area())
    assert (c >= 0).all() and (c <= 1).all()


def test_wall_hits_give_arc_length_and_outward_normal():
    square = Polygon.from_points(UNIT)                       # perimeter 4, counter-clockwise from (0, 0)
    o = np.array([[0.5, -1.0], [2.0, 0.25], [-1.0, 2.0]])
    d = np.array([[0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]])
    dist, arc, normal = square.wall_hits(o, d)
    np.testing.assert_allclose(dist, [1.0, 1.0, np.inf])    # the bottom wall, the right wall, a miss
    np.testing.assert_allclose(arc, [0.5 / 4, (1 + 0.25) / 4, 0.0])
    np.testing.assert_allclose(normal, [[0, -1], [1, 0], [0, 0]], atol=1e-12)
