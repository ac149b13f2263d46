#include "bindings.hpp"

#include "slideplan/contact_frame.hpp"
#include "slideplan/mesh.hpp"
#include "slideplan/robot_model.hpp"
#include "slideplan/straight_line.hpp"

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace py = pybind11;

namespace slideplan::bindings
{
    namespace
    {
        std::shared_ptr<RobotModel> makeRobot(const std::string &xml, const std::string &source, const std::string &directory,
                                              const std::string &tipLink, const Eigen::Matrix4d &basePose,
                                              const std::string &baseLink, const Eigen::Matrix4d &tipOffset,
                                              const std::map<std::string, double> &fixedJoints,
                                              const std::vector<std::string> &packageDirs)
        {
            RobotSpec spec;
            spec.urdf = xml;
            spec.source = source;
            spec.directory = directory;
            spec.packageDirs = packageDirs;
            spec.basePose = toIsometry(basePose);
            spec.baseLink = baseLink;
            spec.tipLink = tipLink;
            spec.tipOffset = toIsometry(tipOffset);
            spec.fixedJoints = fixedJoints;
            py::gil_scoped_release release;  // meshes may take a while to load
            return std::make_shared<RobotModel>(spec);
        }
    }  // namespace

    void bindRobot(py::module_ &module)
    {
        module.attr("concave_hull_ratio") = kConcaveHullRatio;
        py::class_<IkOptions>(module, "IkOptions", "Options of the damped-least-squares inverse kinematics.")
            .def(py::init<>())
            .def_readwrite("max_iterations", &IkOptions::maxIterations, "Iterations per attempt.")
            .def_readwrite("max_attempts", &IkOptions::maxAttempts, "The seed, then random restarts.")
            .def_readwrite("position_tolerance", &IkOptions::positionTolerance, "Metres.")
            .def_readwrite("orientation_tolerance", &IkOptions::orientationTolerance, "Radians.")
            .def_readwrite("rotation_tolerance", &IkOptions::rotationTolerance,
                           "Rotation tolerated about the target frame's x, y, z (or the world's with world_axes) before "
                           "it counts (rad); pi frees an axis, 0 asks for the orientation exactly.")
            .def_readwrite("world_axes", &IkOptions::worldAxes, "rotation_tolerance is about the world's axes.");

        module.def("contact_ik_options", &contactIkOptions, py::arg("robot"),
                   "IK options for a fingertip contact pose: the yaw left free for an arm with fewer than six joints "
                   "(Eq. 3 does not constrain it).");

        py::class_<RobotModel, std::shared_ptr<RobotModel>>(module, "RobotModel",
                                                            "A serial arm from a URDF (urdfdom + KDL).")
            .def(py::init([](const std::string &path, const std::string &tipLink, const Eigen::Matrix4d &basePose,
                             const std::string &baseLink, const Eigen::Matrix4d &tipOffset,
                             const std::map<std::string, double> &fixedJoints, const std::vector<std::string> &packageDirs) {
                     std::ifstream file(path);
                     if (!file)
                         throw std::invalid_argument(path + ": cannot open URDF file");
                     std::stringstream text;
                     text << file.rdbuf();
                     return makeRobot(text.str(), path, std::filesystem::path(path).parent_path().string(), tipLink,
                                      basePose, baseLink, tipOffset, fixedJoints, packageDirs);
                 }),
                 py::arg("urdf_path"), py::arg("tip_link") = "fingertip_contact",
                 py::arg("base_pose") = Eigen::Matrix4d::Identity(), py::arg("base_link") = "",
                 py::arg("tip_offset") = Eigen::Matrix4d::Identity(), py::arg("fixed_joints") = std::map<std::string, double>(),
                 py::arg("package_dirs") = std::vector<std::string>(),
                 "Load a URDF file.\n\n"
                 "urdf_path: the file (relative mesh names resolve next to it); tip_link, tip_offset (4x4): the contact "
                 "frame F = tip_link * tip_offset moved by fk(); base_pose (4x4): world pose of the URDF root link; "
                 "base_link: root of the planned chain ('' = URDF root); fixed_joints: joints held at a value, off the "
                 "planned chain (mimic joints follow); package_dirs: where package://NAME/... mesh URIs resolve.\n"
                 "Raises ValueError naming the file and key for anything wrong.")
            .def_static("from_string", &makeRobot, py::arg("urdf_xml"), py::arg("source") = "<string>",
                        py::arg("directory") = "", py::arg("tip_link") = "fingertip_contact",
                        py::arg("base_pose") = Eigen::Matrix4d::Identity(), py::arg("base_link") = "",
                        py::arg("tip_offset") = Eigen::Matrix4d::Identity(),
                        py::arg("fixed_joints") = std::map<std::string, double>(),
                        py::arg("package_dirs") = std::vector<std::string>(),
                        "Build from URDF text: source names it in messages, directory is where relative mesh "
                        "names resolve; the other arguments as for the constructor.")
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
            .def_property_readonly("collision_meshes",
                                   [](const RobotModel &robot) {
                                       std::vector<std::tuple<std::string, std::string, double, bool>> meshes;
                                       for (const auto &link : robot.links())
                                           for (const auto &shape : link.shapes)
                                               if (shape.type == LinkShape::Type::Mesh)
                                                   meshes.emplace_back(link.name, shape.meshFile, shape.hullRatio,
                                                                       shape.surface != nullptr);
                                       return meshes;
                                   },
                                   "Every collision mesh as (link, file, hull_ratio, exact): hull_ratio is its convex "
                                   "hull's volume over its own; exact means it is "
                                   "checked as its triangles (a hand link, moved by the last joint of the chain, whose hull would "
                                   "fill a concavity), else as its hull.")
            .def("fk", [](const RobotModel &robot, const Eigen::VectorXd &q) { return robot.fk(q).matrix(); },
                 py::arg("q"), "Gamma(q): world pose (4x4) of the tip frame.")
            .def("link_pose",
                 [](const RobotModel &robot, const Eigen::VectorXd &q, const std::string &link) {
                     return robot.linkPose(q, link).matrix();
                 },
                 py::arg("q"), py::arg("link"), "World pose (4x4) of any link.")
            .def(
                "frame_pose",
                [](const RobotModel &robot, const Eigen::VectorXd &q, const std::string &link, const Eigen::Matrix4d &offset) {
                    return robot.framePose(q, link, toIsometry(offset)).matrix();
                },
                py::arg("q"), py::arg("link"), py::arg("offset") = Eigen::Matrix4d::Identity(),
                "World pose (4x4) of link * offset (e.g. the grasp frame).")
            .def_property_readonly("velocity_limits", &RobotModel::velocityLimits,
                                   "URDF <limit velocity> of the chain joints (0 where the URDF gives none).")
            .def("jacobian", &RobotModel::jacobian, py::arg("q"),
                 "Geometric Jacobian (6 x dof) of the tip frame in the world frame: linear rows first.")
            .def(
                "ik",
                [](const RobotModel &robot, const Eigen::Matrix4d &target, const std::optional<Eigen::VectorXd> &seed,
                   std::uint64_t rngSeed, const IkOptions &options, const std::string &link,
                   const Eigen::Matrix4d &offset) -> std::optional<Eigen::VectorXd> {
                    std::mt19937_64 rng(rngSeed);
                    Eigen::VectorXd solution;
                    const Eigen::Isometry3d pose = toIsometry(target), frame = toIsometry(offset);
                    const Eigen::VectorXd start = seed ? *seed : Eigen::VectorXd();
                    py::gil_scoped_release release;
                    const bool solved = link.empty() ? robot.ik(pose, start, rng, solution, options)
                                                     : robot.ikForLink(link, pose, start, rng, solution, options, frame);
                    if (!solved)
                        return std::nullopt;
                    return solution;
                },
                py::arg("target"), py::arg("seed") = py::none(), py::arg("rng_seed") = 0,
                py::arg("options") = IkOptions(), py::arg("link") = "", py::arg("offset") = Eigen::Matrix4d::Identity(),
                "Gamma~(target): joint configuration within limits reaching the 4x4 target pose of the tip (or of "
                "`link` x `offset`, e.g. the grasp frame), or None. Deterministic for a given rng_seed.")
            .def(
                "random_configuration",
                [](const RobotModel &robot, std::uint64_t rngSeed) {
                    std::mt19937_64 rng(rngSeed);
                    return robot.randomConfiguration(rng);
                },
                py::arg("rng_seed"), "A uniformly random configuration within the joint limits.");

        // One straight line for the planner's lift check and the execution's straight moves.
        module.attr("LIFT_STEP_M") = kLiftStep;
        module.attr("LIFT_JOINT_STEP_RAD") = kLiftJointStep;
        module.def(
            "straight_line",
            [](const RobotModel &robot, const Eigen::VectorXd &q, const Eigen::Vector3d &offset, const IkOptions &options,
               std::uint64_t rngSeed, const std::string &link, const Eigen::Matrix4d &frame) -> std::optional<Eigen::MatrixXd> {
                if (q.size() != static_cast<long>(robot.dof()) || !q.allFinite() || !offset.allFinite())
                    throw std::invalid_argument("q must be " + std::to_string(robot.dof()) +
                                                " finite joint values and offset 3 finite numbers");
                const Eigen::Isometry3d pose = toIsometry(frame);
                std::optional<std::vector<Eigen::VectorXd>> path;
                {
                    py::gil_scoped_release release;
                    const Eigen::Isometry3d start = link.empty() ? robot.fk(q) : robot.framePose(q, link, pose);
                    path = straightLine(robot, q, start, offset, options, rngSeed, link, pose);
                }
                if (!path)
                    return std::nullopt;
                Eigen::MatrixXd rows(static_cast<long>(path->size()), q.size());
                for (std::size_t i = 0; i < path->size(); ++i)
                    rows.row(static_cast<long>(i)) = (*path)[i].transpose();
                return rows;
            },
            py::arg("robot"), py::arg("q"), py::arg("offset"), py::arg("options") = IkOptions(), py::arg("rng_seed") = 0,
            py::arg("link") = "", py::arg("frame") = Eigen::Matrix4d::Identity(),
            "The configurations moving a frame of the arm in a straight line from where it is, its orientation kept "
            "(straight_line.hpp): the lift after the grasp and the fingertip's straight moves, as the planner's lift "
            "check makes them. Releases the GIL.\n\n"
            "Args:\n"
            "    robot: the RobotModel.\n"
            "    q: (dof,) the configuration the move starts from.\n"
            "    offset: (3,) where the frame goes from its pose at q (m, world frame).\n"
            "    options: the IkOptions of each step (contact_ik_options(robot) for the fingertip: its yaw free on "
            "an arm with fewer than six joints).\n"
            "    rng_seed: seeds each step's IK restarts afresh (deterministic for a given seed).\n"
            "    link: the link whose frame moves; empty (the default) for the tip frame.\n"
            "    frame: 4x4 offset of the moving frame on link (e.g. the grasp frame); ignored for the tip.\n\n"
            "Returns:\n"
            "    (M, dof) array: q, then one configuration per step of at most LIFT_STEP_M, each IK seeded by the one "
            "before; None where a step has no IK or turns a joint more than LIFT_JOINT_STEP_RAD.\n\n"
            "Raises:\n"
            "    ValueError: q is not dof finite numbers, offset not 3, frame not a pose, or link not a link moved by "
            "every chain joint.");

        module.def(
            "resolve_uri",
            [](const std::string &uri, const std::string &directory, const std::vector<std::string> &packageDirs) {
                return resolveMeshUri(uri, directory, packageDirs, uri);
            },
            py::arg("uri"), py::arg("directory"), py::arg("package_dirs"),
            "The file a URDF URI names: package://NAME/rest in package_dirs (DIR/NAME/rest, or DIR/rest when DIR "
            "is named NAME), file://, or relative to directory. Raises ValueError if it does not exist.");
    }
}  // namespace slideplan::bindings
