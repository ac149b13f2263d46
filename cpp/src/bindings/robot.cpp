#include "bindings.hpp"

#include "slideplan/robot_model.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace py = pybind11;

namespace slideplan::bindings
{
    void bindRobot(py::module_ &module)
    {
        py::class_<IkOptions>(module, "IkOptions", "Options of the damped-least-squares inverse kinematics.")
            .def(py::init<>())
            .def_readwrite("max_iterations", &IkOptions::maxIterations, "Iterations per attempt.")
            .def_readwrite("max_attempts", &IkOptions::maxAttempts, "The seed, then random restarts.")
            .def_readwrite("position_tolerance", &IkOptions::positionTolerance, "Metres.")
            .def_readwrite("orientation_tolerance", &IkOptions::orientationTolerance, "Radians.");

        py::class_<RobotModel, std::shared_ptr<RobotModel>>(module, "RobotModel",
                                                            "A serial arm from a URDF (urdfdom + KDL).")
            .def(py::init([](const std::string &path, const std::string &tipLink, const Eigen::Matrix4d &basePose) {
                     return std::make_shared<RobotModel>(RobotModel::fromFile(path, tipLink, toIsometry(basePose)));
                 }),
                 py::arg("urdf_path"), py::arg("tip_link") = "fingertip_contact",
                 py::arg("base_pose") = Eigen::Matrix4d::Identity(),
                 "Load a URDF file; tip_link is the frame Gamma() moves; base_pose (4x4) places the root link.")
            .def_static(
                "from_string",
                [](const std::string &xml, const std::string &tipLink, const Eigen::Matrix4d &basePose) {
                    return std::make_shared<RobotModel>(xml, tipLink, toIsometry(basePose), "<string>");
                },
                py::arg("urdf_xml"), py::arg("tip_link") = "fingertip_contact",
                py::arg("base_pose") = Eigen::Matrix4d::Identity(), "Build from URDF text.")
            .def_property_readonly("dof", &RobotModel::dof, "Number of joints of the chain.")
            .def_property_readonly("joint_names", &RobotModel::jointNames, "Chain joint names, root to tip.")
            .def_property_readonly("lower_limits", &RobotModel::lowerLimits, "Lower joint limits.")
            .def_property_readonly("upper_limits", &RobotModel::upperLimits, "Upper joint limits.")
            .def_property_readonly("tip_link", &RobotModel::tipLink, "The frame moved by fk().")
            .def_property_readonly("link_names",
                                   [](const RobotModel &robot) {
                                       std::vector<std::string> names;
                                       for (const auto &link : robot.links())
                                           names.push_back(link.name);
                                       return names;
                                   },
                                   "All links, parents first.")
            .def("fk", [](const RobotModel &robot, const Eigen::VectorXd &q) { return robot.fk(q).matrix(); },
                 py::arg("q"), "Gamma(q): world pose (4x4) of the tip frame.")
            .def("link_pose",
                 [](const RobotModel &robot, const Eigen::VectorXd &q, const std::string &link) {
                     return robot.linkPose(q, link).matrix();
                 },
                 py::arg("q"), py::arg("link"), "World pose (4x4) of any link.")
            .def("jacobian", &RobotModel::jacobian, py::arg("q"),
                 "Geometric Jacobian (6 x dof) of the tip frame in the world frame: linear rows first.")
            .def(
                "ik",
                [](const RobotModel &robot, const Eigen::Matrix4d &target, const std::optional<Eigen::VectorXd> &seed,
                   std::uint64_t rngSeed, const IkOptions &options, const std::string &link) -> std::optional<Eigen::VectorXd> {
                    std::mt19937_64 rng(rngSeed);
                    Eigen::VectorXd solution;
                    const Eigen::Isometry3d pose = toIsometry(target);
                    const Eigen::VectorXd start = seed ? *seed : Eigen::VectorXd();
                    py::gil_scoped_release release;
                    const bool solved = link.empty() ? robot.ik(pose, start, rng, solution, options)
                                                     : robot.ikForLink(link, pose, start, rng, solution, options);
                    if (!solved)
                        return std::nullopt;
                    return solution;
                },
                py::arg("target"), py::arg("seed") = py::none(), py::arg("rng_seed") = 0,
                py::arg("options") = IkOptions(), py::arg("link") = "",
                "Gamma~(target): joint configuration within limits reaching the 4x4 target pose of the tip (or of "
                "`link`), or None. Deterministic for a given rng_seed.")
            .def(
                "random_configuration",
                [](const RobotModel &robot, std::uint64_t rngSeed) {
                    std::mt19937_64 rng(rngSeed);
                    return robot.randomConfiguration(rng);
                },
                py::arg("rng_seed"), "A uniformly random configuration within the joint limits.");
    }
}  // namespace slideplan::bindings
