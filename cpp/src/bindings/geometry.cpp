#include "bindings.hpp"

#include "slideplan/area_centroid.hpp"
#include "slideplan/contact_frame.hpp"
#include "slideplan/geometry.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace py = pybind11;

namespace slideplan::bindings
{
    void bindGeometry(py::module_ &module)
    {
        py::class_<EdgeQuery>(module, "EdgeQuery", "The edge of the support polygon closest to a point.")
            .def_readonly("edge", &EdgeQuery::edge, "Index i of edge (e_i, e_i+1).")
            .def_readonly("distance", &EdgeQuery::distance, "Distance from the point to the edge.")
            .def_readonly("closest", &EdgeQuery::closest, "Closest point on the edge.")
            .def_readonly("outward_normal", &EdgeQuery::outwardNormal, "Unit edge normal pointing out of Q.");

        py::class_<SupportSurface>(module, "SupportSurface",
                                   "Support polygon Q at a height (paper IV-B); any simple polygon, stored CCW.")
            .def(py::init<const Polygon2 &, double>(), py::arg("vertices"), py::arg("height"),
                 "Raises ValueError for < 3 or > MAX_VERTICES vertices, non-finite values, self-intersection or "
                 "zero area.")
            .def_readonly_static("MAX_VERTICES", &SupportSurface::kMaxVertices, "Most vertices a polygon may have.")
            .def("contains", &SupportSurface::contains, py::arg("point"), "Point-in-polygon test of a 2-D point.")
            .def("signed_distance", &SupportSurface::signedDistance, py::arg("point"),
                 "Distance to the boundary, positive inside.")
            .def("closest_edge", &SupportSurface::closestEdge, py::arg("point"), "Closest edge to a 2-D point.")
            .def_property_readonly("vertices", &SupportSurface::vertices, "Vertices (n, 2), counter-clockwise.")
            .def_property_readonly("height", &SupportSurface::height, "z of the table top.")
            .def_property_readonly("area", &SupportSurface::area, "Polygon area.")
            .def_property_readonly("is_convex", &SupportSurface::isConvex, "Whether Q is convex.")
            .def_property_readonly("triangles", &SupportSurface::triangles, "Ear-clipping triangles (vertex indices).");

        module.def("area_centroid", &areaCentroid, py::arg("points"), py::call_guard<py::gil_scoped_release>(),
                   "Centre of mass of a uniform thin plate known by (N, 2) points of its top surface: the area "
                   "centroid of the alpha shape they cover, whatever their density (the points' mean if they "
                   "cover no area). Raises ValueError for no points or a non-finite one.");
        module.def("contact_rotation", &contactRotation, py::arg("yaw"), py::arg("pitch"),
                   "r(alpha, beta) of Eqs. 3-4: fingertip orientation for yaw alpha and pitch beta (3x3).");
        module.def(
            "contact_angles",
            [](const Eigen::Matrix3d &rotation) {
                const ContactAngles angles = contactAngles(rotation);
                return py::make_tuple(angles.yaw, angles.pitch, angles.roll);
            },
            py::arg("rotation"), "(yaw, pitch, roll) of a fingertip orientation relative to the horizontal surface.");
    }
}  // namespace slideplan::bindings
