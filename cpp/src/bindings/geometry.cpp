#include "bindings.hpp"

#include "slideplan/area_centroid.hpp"
#include "slideplan/contact_frame.hpp"
#include "slideplan/geometry.hpp"
#include "slideplan/hold_model.hpp"
#include "slideplan/outline_icp.hpp"

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
        module.def(
            "estimate_hold",
            [](const Points2 &points, const Eigen::Vector2d &com, double thickness, const Eigen::Vector2d &grasp,
               double beyond, const Eigen::Vector2d &outward, const PlannerParams &params) {
                const HoldEstimate e = estimateHold(plateRegion(points), com, thickness, grasp, beyond, outward, params);
                py::dict result;
                result["patch_area"] = e.patchArea;
                result["mass"] = e.mass;
                result["lever"] = e.lever;
                result["patch_length"] = e.patchLength;
                result["demand"] = e.demand;
                result["capacity"] = e.capacity;
                result["holds"] = e.holds;
                return result;
            },
            py::arg("points"), py::arg("com"), py::arg("thickness"), py::arg("grasp"), py::arg("beyond"), py::arg("outward"),
            py::arg("params"),
            "The grasp model (hold_model.hpp): whether the hand closed at `grasp` (H_g in the table plane, `beyond` m "
            "beyond the table edge, approaching along -`outward`) holds the object known by its (N, 2) top points at their final pose (the region "
            "area_centroid finds) and its centre of mass there. A dict: patch_area (m^2), mass (kg), lever (m), "
            "patch_length (m), demand and capacity (N m), holds. Raises ValueError as area_centroid.");
        py::class_<OutlineIcp>(module, "OutlineIcp",
                               "Trimmed 2-D ICP of edge points to an object's outline (the closed loop's tracker). "
                               "Immutable: one instance may serve many threads.")
            .def(py::init<Points2, OutlineIcp::IndexGrid, const Eigen::Vector2d &, double, double>(), py::arg("model"),
                 py::arg("grid"), py::arg("low"), py::arg("cell"), py::arg("inlier"),
                 "model: the outline's points (M, 2), reference frame. grid: (I, J) int64, for each cell (cell (i, j) "
                 "spans x from low[0] + i cell, y from low[1] + j cell) the index of the model point nearest it. "
                 "inlier: an edge point this near the outline is explained by it (m). Raises ValueError for no "
                 "model points, a non-finite value, an empty grid or one indexing outside the model, or a cell or "
                 "inlier distance that is not positive.")
            .def(
                "nearest",
                [](const OutlineIcp &icp, const Points2 &points, const Eigen::Vector3d &motion, bool exact) {
                    Eigen::VectorXd distance;
                    Eigen::VectorXi index;
                    {
                        py::gil_scoped_release release;
                        icp.nearest(points, motion, exact, distance, index);
                    }
                    return py::make_tuple(distance, index);
                },
                py::arg("points"), py::arg("motion"), py::arg("exact") = true,
                "(distance (N,), index (N,)) of the outline point nearest each of points (N, 2), brought into the "
                "reference frame by the inverse of motion (x, y, yaw); exact=False: by the grid.")
            .def(
                "fit",
                [](const OutlineIcp &icp, const Points2 &points, const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> &starts,
                   int iterations, bool exact, double gate) {
                    std::vector<OutlineFit> fits;
                    {
                        py::gil_scoped_release release;
                        fits = icp.fit(points, starts, iterations, exact, gate);
                    }
                    py::list out;
                    for (const OutlineFit &fit : fits)
                        out.append(py::make_tuple(Eigen::Vector3d(fit.motion), fit.inliers, fit.rmse));
                    return out;
                },
                py::arg("points"), py::arg("starts"), py::arg("iterations"), py::arg("exact"), py::arg("gate"),
                "Trimmed ICP of edge points (N, 2) from each of starts (S, 3): per start (motion (3,), inliers, rmse). "
                "iterations: at most per start; exact=False pairs by the grid (the final count is exact); gate: the "
                "first iteration's pair distance cut-off (m). Raises ValueError for a non-finite point or start, or "
                "iterations < 0.");

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
