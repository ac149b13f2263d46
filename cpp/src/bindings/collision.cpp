#include "bindings.hpp"

#include "slideplan/collision.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace py = pybind11;

namespace slideplan::bindings
{
    void bindCollision(py::module_ &module)
    {
        py::enum_<ContactMode>(module, "ContactMode", "Whether the contacting finger may penetrate table and object.")
            .value("SLIDING", ContactMode::Sliding, "Contact links excluded from table and object checks.")
            .value("FREE", ContactMode::Free, "Every link checked against everything.");

        py::class_<BoxObstacle>(module, "BoxObstacle", "A box obstacle: 4x4 world pose and full extents.")
            .def(py::init([](const Eigen::Matrix4d &pose, const Eigen::Vector3d &size) {
                     return BoxObstacle{toIsometry(pose), size};
                 }),
                 py::arg("pose"), py::arg("size"))
            .def_property_readonly("pose", [](const BoxObstacle &box) { return box.pose.matrix(); }, "4x4 world pose.")
            .def_readonly("size", &BoxObstacle::size, "Full extents (x, y, z).");

        py::class_<CollisionWorld, std::shared_ptr<CollisionWorld>>(module, "CollisionWorld",
                                                                    "Robot, table prism, obstacles and object (FCL).")
            .def(py::init<std::shared_ptr<const RobotModel>, const SupportSurface &, const std::vector<BoxObstacle> &,
                          const std::vector<std::string> &, double>(),
                 py::arg("robot"), py::arg("table"), py::arg("obstacles") = std::vector<BoxObstacle>(),
                 py::arg("contact_links") = std::vector<std::string>(), py::arg("table_depth") = 0.75)
            .def("is_valid", &CollisionWorld::isValid, py::arg("q"), py::arg("mode") = ContactMode::Sliding,
                 "True if q is free of collisions.")
            .def("collisions", &CollisionWorld::collisions, py::arg("q"), py::arg("mode") = ContactMode::Sliding,
                 "Colliding (link, link-or-obstacle) name pairs at q.")
            .def(
                "set_object",
                [](CollisionWorld &world, const Eigen::Matrix<double, Eigen::Dynamic, 2> &outline, double topZ) {
                    std::vector<Eigen::Vector2d> points;
                    for (int i = 0; i < outline.rows(); ++i)
                        points.emplace_back(outline.row(i));
                    world.setObject(points, topZ);
                },
                py::arg("outline_xy"), py::arg("top_z"),
                "Add the object as a prism over the convex hull of outline_xy, from the table top to top_z.")
            .def("clear_object", &CollisionWorld::clearObject, "Remove the object.")
            .def_property_readonly("self_pair_count", &CollisionWorld::selfPairCount, "Link pairs checked for self-collision.");
    }
}  // namespace slideplan::bindings
