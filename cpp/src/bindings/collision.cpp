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

        py::class_<Obstacle> obstacle(module, "Obstacle",
                                      "A static obstacle: a box, an upright cylinder or a vertical prism (docs/design.md 5 [[obstacles]]).");
        py::enum_<Obstacle::Shape>(obstacle, "Shape")
            .value("BOX", Obstacle::Shape::Box)
            .value("CYLINDER", Obstacle::Shape::Cylinder)
            .value("PRISM", Obstacle::Shape::Prism);
        obstacle.def_readonly("shape", &Obstacle::shape)
            .def_property_readonly("pose", [](const Obstacle &o) { return o.pose.matrix(); }, "4x4 world pose (centre).")
            .def_readonly("size", &Obstacle::size, "Box: full extents; cylinder: (radius, height, 0); prism: (0, 0, height).")
            .def("covers", &Obstacle::covers, py::arg("point"), "Whether (x, y) lies in the obstacle's footprint.");
        module.def(
            "BoxObstacle",
            [](const Eigen::Matrix4d &pose, const Eigen::Vector3d &size) {
                return Obstacle{Obstacle::Shape::Box, toIsometry(pose), size, {}};
            },
            py::arg("pose"), py::arg("size"), "A box: 4x4 world pose of its centre (upright) and full extents.");
        module.def(
            "CylinderObstacle",
            [](const Eigen::Matrix4d &pose, double radius, double height) {
                return Obstacle{Obstacle::Shape::Cylinder, toIsometry(pose), Eigen::Vector3d(radius, height, 0.0), {}};
            },
            py::arg("pose"), py::arg("radius"), py::arg("height"),
            "An upright cylinder (a can, a mug): 4x4 world pose of its centre, radius and height.");
        module.def(
            "PrismObstacle",
            [](const Eigen::Matrix<double, Eigen::Dynamic, 2> &polygon, double bottom, double height) {
                Obstacle prism{Obstacle::Shape::Prism, Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.0, 0.0, height), {}};
                prism.pose.translation().z() = bottom + 0.5 * height;
                for (int i = 0; i < polygon.rows(); ++i)
                    prism.polygon.emplace_back(polygon.row(i).transpose());
                return prism;
            },
            py::arg("polygon"), py::arg("bottom"), py::arg("height"),
            "A vertical prism (another thin object): convex counter-clockwise footprint (n, 2), bottom z, height.");

        py::class_<CollisionWorld, std::shared_ptr<CollisionWorld>>(module, "CollisionWorld",
                                                                    "Robot, table prism, obstacles and object (FCL).")
            .def(py::init<std::shared_ptr<const RobotModel>, const SupportSurface &, const std::vector<Obstacle> &,
                          const std::vector<std::string> &, double>(),
                 py::arg("robot"), py::arg("table"), py::arg("obstacles") = std::vector<Obstacle>(),
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
            .def("hidden_lines", &CollisionWorld::hiddenLines, py::arg("q"), py::arg("eye"), py::arg("points"), py::arg("radius"),
                 "For each row of points (n, 3), whether a link at q crosses the line of sight to it from eye (3,), a "
                 "capsule of radius (m) around it: what a camera at eye cannot see with the robot there. Only the robot "
                 "is checked. Raises ValueError for bad sizes, non-finite values, radius <= 0 or a point at the eye.")
            .def("clear_object", &CollisionWorld::clearObject, "Remove the object.")
            .def(
                "rigid_collision",
                [](const CollisionWorld &world, const std::string &link, const Eigen::Matrix4d &pose) {
                    return world.rigidCollision(link, toIsometry(pose));
                },
                py::arg("link"), py::arg("pose"),
                "What the links rigid with `link` meet with `link` at the world pose (4x4): 'link-obstacle' for the "
                "first hit on the table or an obstacle, '' if nothing (the rest of the robot and the object are not "
                "checked). Raises ValueError for an unknown link.")
            .def_property_readonly("self_pair_count", &CollisionWorld::selfPairCount, "Link pairs checked for self-collision.")
            .def_property_readonly("always_in_contact", &CollisionWorld::alwaysInContact,
                                   "Link pairs left unchecked for being in contact in almost every random configuration "
                                   "(overlapping shapes, or a held joint value that puts them together).");
    }
}  // namespace slideplan::bindings
