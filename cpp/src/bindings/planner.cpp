#include "bindings.hpp"

#include "slideplan/ompl_peer.hpp"
#include "slideplan/planner.hpp"
#include "slideplan/timing.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <thread>

namespace py = pybind11;

namespace slideplan::bindings
{
    namespace
    {
        Eigen::MatrixXd stack(const std::vector<Eigen::VectorXd> &rows, long columns)
        {
            Eigen::MatrixXd matrix(static_cast<long>(rows.size()), columns);
            for (std::size_t i = 0; i < rows.size(); ++i)
                matrix.row(static_cast<long>(i)) = rows[i].transpose();
            return matrix;
        }

        Eigen::MatrixXd tipPositions(const std::vector<Eigen::Isometry3d> &frames)
        {
            Eigen::MatrixXd positions(static_cast<long>(frames.size()), 3);
            for (std::size_t i = 0; i < frames.size(); ++i)
                positions.row(static_cast<long>(i)) = frames[i].translation().transpose();
            return positions;
        }

        py::dict timedSegment(const TimedPath &path)
        {
            py::dict segment;
            segment["time_from_start"] = path.timeFromStart;
            segment["velocities"] = path.velocities;
            segment["accelerations"] = path.accelerations;
            return segment;
        }

        py::object timingDict(const std::optional<PlanTiming> &timing)
        {
            if (!timing)
                return py::none();
            py::dict block;
            block["trajectory"] = timedSegment(timing->trajectory);
            block["approach"] = timedSegment(timing->approach);
            return std::move(block);
        }

        py::array_t<double> poses(const std::vector<Eigen::Isometry3d> &frames)
        {
            py::array_t<double> out({static_cast<py::ssize_t>(frames.size()), py::ssize_t{4}, py::ssize_t{4}});
            auto view = out.mutable_unchecked<3>();
            for (std::size_t i = 0; i < frames.size(); ++i)
                for (int r = 0; r < 4; ++r)
                    for (int c = 0; c < 4; ++c)
                        view(static_cast<py::ssize_t>(i), r, c) = frames[i].matrix()(r, c);
            return out;
        }

        std::shared_ptr<const SlidingTask> makeTask(std::shared_ptr<const RobotModel> robot, const SupportSurface &table,
                                                    const std::vector<Obstacle> &obstacles,
                                                    const std::vector<std::string> &contactLinks,
                                                    const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints,
                                                    const Eigen::Vector2d &objectCom, const std::string &graspLink,
                                                    const Eigen::Matrix4d &graspOffset, double timeLimit, bool mayOverhang)
        {
            if (!std::isfinite(timeLimit) || timeLimit <= 0.0)
                throw std::invalid_argument("time limit must be a positive number of seconds, got " + std::to_string(timeLimit));
            return std::make_shared<SlidingTask>(SlidingTask::make(robot, std::make_shared<SupportSurface>(table), obstacles,
                                                                   contactLinks, graspLink, toIsometry(graspOffset),
                                                                   objectPoints, objectCom, mayOverhang));
        }

        /// A thread that takes the GIL while the interpreter shuts down is ended by pthread_exit, whose
        /// unwinding through C++ frames aborts the process ("terminate called without an active
        /// exception"): a plan in a daemon thread at exit. Such a thread waits here instead, for the
        /// process to end around it.
        void parkIfFinalizing()
        {
#if PY_VERSION_HEX >= 0x030D0000
            const bool finalizing = Py_IsFinalizing();
#else
            const bool finalizing = _Py_IsFinalizing();
#endif
            while (finalizing)
                std::this_thread::sleep_for(std::chrono::hours(1));
        }

        PlanResult plan(std::shared_ptr<const RobotModel> robot, const SupportSurface &table,
                        const std::vector<Obstacle> &obstacles, const std::vector<std::string> &contactLinks,
                        const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints, const Eigen::Vector2d &objectCom,
                        const PlannerParams &params, std::uint64_t seed, double timeLimit, const std::string &graspLink,
                        const Eigen::Matrix4d &graspOffset, std::shared_ptr<const GraspMap> graspMap,
                        const std::optional<TimingLimits> &timing, const std::optional<Eigen::VectorXd> &startConfig)
        {
            // Planning from a state, the object may already overhang an edge (the end of a slide, seen again).
            const auto task = makeTask(robot, table, obstacles, contactLinks, objectPoints, objectCom, graspLink, graspOffset,
                                       timeLimit, startConfig.has_value());

            // The GIL is released while planning; every 100 ms the termination condition takes it back
            // briefly to let Python run its signal handlers, so Ctrl-C stops planning promptly.
            using Clock = std::chrono::steady_clock;
            // A limit beyond what the clock can add (about 9e9 s in nanoseconds) is no limit, not an overflow.
            const double seconds = std::min(timeLimit, 1e9);
            const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
            auto lastSignalCheck = Clock::now();
            std::atomic<bool> interrupted{false};
            const ompl::base::PlannerTerminationCondition ptc([&] {
                const auto now = Clock::now();
                if (now >= deadline || interrupted)
                    return true;
                if (now - lastSignalCheck > std::chrono::milliseconds(100))
                {
                    lastSignalCheck = now;
                    parkIfFinalizing();
                    py::gil_scoped_acquire gil;
                    if (PyErr_CheckSignals() != 0)
                        interrupted = true;
                }
                return interrupted.load();
            });
            PlanResult result;
            {
                py::gil_scoped_release release;
                result = planSliding(task, params, seed, ptc, std::move(graspMap), startConfig);
                if (timing && result.status == "solved")
                    result.timing = timePlan(*robot, stack(result.trajectory, robot->dof()), tipPositions(result.fingertipPoses),
                                             stack(result.approach, robot->dof()), task->surfaceZ, *timing);
                parkIfFinalizing();  // before the release's destructor takes the GIL back
            }
            if (interrupted)
                throw py::error_already_set();  // the KeyboardInterrupt raised by the signal handler
            return result;
        }

        /// PlannerParams, one attribute per registry entry, and parameters() (the registry itself).
        void bindParams(py::module_ &module)
        {
            py::register_exception<InvalidStartConfig>(module, "InvalidStartConfig", PyExc_ValueError);
            auto paramsClass = py::class_<PlannerParams>(module, "PlannerParams",
                                                         "Every planner parameter, one attribute per entry of parameters().");
            paramsClass.def(py::init<>(), "Every parameter at its default.");
            // One attribute per registry entry: the registry is the only list of parameters.
            for (const ParameterSpec &spec : parameters())
                paramsClass.def_property(
                    spec.name.c_str(),
                    [&spec](const PlannerParams &p) -> py::object {
                        const double value = spec.get(p);
                        if (spec.member.index() == 2)
                            return py::bool_(value != 0.0);
                        if (spec.member.index() == 1)
                            return py::int_(static_cast<long long>(value));
                        return py::float_(value);
                    },
                    [&spec](PlannerParams &p, double value) { spec.set(p, value); }, spec.doc.c_str());
            paramsClass
                .def_property(
                    "policy", [](const PlannerParams &p) { return rootPolicyName(p.policy); },
                    [](PlannerParams &p, const std::string &name) { p.policy = rootPolicyFromName(name); },
                    "Root policy: 'slideplan' (Algorithm 1), 'cbirrt' or 'cbirrt2' (our reading of the baselines of V-6).")
                .def(
                    "validate",
                    [](const PlannerParams &p, const std::optional<std::vector<std::string>> &given) {
                        p.validate(given ? &*given : nullptr);
                    },
                    py::arg("given") = py::none(),
                    "Raise ValueError 'planner parameter NAME ...' naming the first parameter out of its bounds, or both "
                    "parameters of an inconsistent pair. given: None checks every parameter; a list of names checks only "
                    "those, and a pair (delta_beta < beta0, dz_min <= dz_max) only when it names both.")
                .def_static("as_published", &PlannerParams::asPublished,
                            "Every parameter with a paper value at it (every departure off); the others at their defaults.");
            module.def(
                "parameters",
                [] {
                    py::list all;
                    for (const ParameterSpec &spec : parameters())
                    {
                        py::dict entry;
                        entry["name"] = spec.name;
                        entry["kind"] = spec.kind();
                        entry["unit"] = spec.unit;
                        entry["default"] = spec.defaultValue;
                        entry["lower"] = spec.lower;
                        entry["upper"] = spec.upper;
                        entry["lower_open"] = spec.lowerOpen;
                        entry["upper_open"] = spec.upperOpen;
                        entry["paper"] = spec.paper ? py::object(py::float_(*spec.paper)) : py::object(py::none());
                        entry["paper_source"] = spec.paperSource;
                        entry["hand"] = spec.hand;
                        entry["grasp_map"] = spec.graspMap;
                        entry["verify"] = spec.verify;
                        entry["doc"] = spec.doc;
                        all.append(entry);
                    }
                    return all;
                },
                "The parameter registry (params.cpp), in order: one dict per parameter with name, kind ('real', 'int', "
                "'bool'), unit, default, lower, upper, lower_open, upper_open (the bounds), paper (the published value, "
                "None where the paper leaves it open), paper_source, hand (a scene's [hand] params may set it), grasp_map "
                "(the grasp map depends on it), verify (a plan's verification reads it) and doc.");
        }

        /// PlanResult, plan_sliding's answer, and the grasp's IK options.
        void bindResult(py::module_ &module)
        {
            py::class_<PlanResult>(module, "PlanResult", "Result of plan_sliding().")
                .def_readonly("status", &PlanResult::status, "'solved' or 'timeout'.")
                .def_readonly("planner", &PlanResult::planner, "'slideplan', 'cbirrt' or 'cbirrt2'.")
                .def_readonly("planning_time", &PlanResult::planningTime, "Seconds, precomputation included.")
                .def_readonly("start_config", &PlanResult::startConfig, "phi_s.")
                .def_readonly("goal_config", &PlanResult::goalConfig, "phi_g.")
                .def_property_readonly("trajectory", [](const PlanResult &r) { return stack(r.trajectory, r.startConfig.size()); },
                                       "Dense joint path (M, dof), phi_s to phi_g.")
                .def_property_readonly("fingertip_poses", [](const PlanResult &r) { return poses(r.fingertipPoses); },
                                       "Contact frame F per waypoint (M, 4, 4).")
                .def_property_readonly("object_motion",
                                       [](const PlanResult &r) { return py::make_tuple(r.objectMotion.x, r.objectMotion.y, r.objectMotion.yaw); },
                                       "(x, y, yaw): p' = R(yaw) p + (x, y), Eq. 2.")
                .def_readonly("overhang", &PlanResult::overhang, "Overhang u of the final pose (m).")
                .def_property_readonly("grasp_pose", [](const PlanResult &r) { return r.graspPose.matrix(); }, "H_g (4x4).")
                .def_readonly("grasp_config", &PlanResult::graspConfig, "Configuration at the grasp.")
                .def_property_readonly("approach", [](const PlanResult &r) { return stack(r.approach, r.startConfig.size()); },
                                       "Dense joint path (K, dof) from phi_g to the grasp.")
                .def_property_readonly(
                    "stats",
                    [](const PlanResult &r) {
                        py::dict stats;
                        stats["iterations"] = r.stats.iterations;
                        stats["start_roots"] = r.stats.startRoots;
                        stats["goal_roots"] = r.stats.goalRoots;
                        stats["connections"] = r.stats.connections;
                        stats["pairs_checked"] = r.stats.pairsChecked;
                        stats["pairs_rejected"] = r.stats.pairsRejected;
                        stats["nodes"] = r.stats.nodes;
                        stats["root_samples"] = r.stats.rootSamples;
                        stats["precompute_time"] = r.stats.precomputeTime;
                        stats["setup_time"] = r.stats.setupTime;
                        stats["fingertip_path_m"] = r.stats.fingertipPath;
                        stats["yaw_travel_rad"] = r.stats.yawTravel;
                        stats["com_margin_m"] = r.stats.comMargin;
                        stats["rejections"] = r.stats.rejections;
                        return stats;
                    },
                    "Planner statistics.")
                .def_property_readonly("timing", [](const PlanResult &r) { return timingDict(r.timing); },
                                       "The profile asked for with plan_sliding(timing=...) (as time_plan returns it), or None.");

            module.def("grasp_ik_options", &graspIkOptions, py::arg("params"),
                       "IK options for the grasp frame: H_g's orientation within the hand's tolerated rotation "
                       "(grasp_tilt_tolerance, grasp_yaw_tolerance, grasp_roll_tolerance), as the planner asks.");
        }

        /// GraspMap: the grasp map a plan shares, its entries and its restore.
        void bindGraspMap(py::module_ &module)
        {
            py::class_<GraspMap, std::shared_ptr<GraspMap>>(
                module, "GraspMap",
                "Which 1 cm stretches of the table's edges admit a reachable, liftable side grasp (grasp_map.hpp): each "
                "probed once when a plan first asks, with an answer that depends only on the geometry, so plans in any "
                "threads may share one map and get the plans they would get alone.")
                .def(py::init([](std::shared_ptr<const RobotModel> robot, const SupportSurface &table, const std::string &graspLink,
                                 const Eigen::Matrix4d &graspOffset, double thickness, const PlannerParams &params) {
                         return std::make_shared<GraspMap>(robot, std::make_shared<SupportSurface>(table), graspLink,
                                                           toIsometry(graspOffset), thickness, params);
                     }),
                     py::arg("robot"), py::arg("table"), py::arg("grasp_link"), py::arg("grasp_offset"), py::arg("thickness"),
                     py::arg("params"),
                     "robot: the shared RobotModel; table: SupportSurface Q; grasp_link, grasp_offset (4x4): H_g; thickness: "
                     "the object's (m); params: PlannerParams (grasp_standoff, u_star, grasp_lift, grasp_flip are used). "
                     "Raises ValueError for an unknown grasp link or a negative thickness.")
                .def_property_readonly("probed", &GraspMap::probed, "Stretches probed so far.")
                .def("stretch_count", &GraspMap::stretchCount, py::arg("edge"),
                     "How many 1 cm stretches edge `edge` (from vertex edge to edge + 1) has. Raises ValueError for no such edge.")
                .def(
                    "stretch_grasp",
                    [](const GraspMap &map, int edge, long cell) { return map.stretchGrasp({edge, cell}).matrix(); },
                    py::arg("edge"), py::arg("cell"),
                    "H_g (4x4) the probe of stretch `cell` of `edge` tries, the hand as given: grasp_standoff (at least "
                    "u*/2) beyond the edge, mid-thickness. Raises ValueError for no such stretch.")
                .def(
                    "grasp_on",
                    [](const GraspMap &map, int edge, long cell) -> std::optional<Eigen::VectorXd> {
                        map.stretchGrasp({edge, cell});  // refuses a stretch that is not there
                        py::gil_scoped_release release;
                        Eigen::VectorXd grasp = map.answer({edge, cell});
                        if (grasp.size() == 0)
                            return std::nullopt;
                        return grasp;
                    },
                    py::arg("edge"), py::arg("cell"),
                    "The liftable grasp configuration of a stretch (probed on first use, as plans do), or None if no side "
                    "grasp is reachable there. Raises ValueError for no such stretch.")
                .def(
                    "entries",
                    [](const GraspMap &map) {
                        py::list out;
                        for (const GraspMap::Entry &entry : map.entries())
                            out.append(py::make_tuple(entry.edge, entry.cell, entry.grasp));
                        return out;
                    },
                    "Every stretch probed so far as (edge, cell, grasp configuration; empty if unreachable), in (edge, cell) "
                    "order: what a persisted map stores.")
                .def(
                    "remember",
                    [](GraspMap &map, const std::vector<std::tuple<int, long, Eigen::VectorXd>> &entries) {
                        std::vector<GraspMap::Entry> taken;
                        taken.reserve(entries.size());
                        for (const auto &[edge, cell, grasp] : entries)
                            taken.push_back({edge, cell, grasp});
                        map.remember(taken);
                    },
                    py::arg("entries"),
                    "Take the entries() of an earlier map of the same inputs, so that their stretches are not probed "
                    "again (known stretches keep their answer). Raises ValueError, taking nothing, for an entry that names "
                    "no edge, a negative cell, or a grasp not empty and not of the robot's joint count.");
        }

        /// TimingLimits and time_path: the rest-to-rest profile of timing.hpp.
        void bindTiming(py::module_ &module)
        {
            py::class_<TimingLimits>(module, "TimingLimits", "Limits of the time parameterization (timing.hpp).")
                .def(py::init([](Eigen::VectorXd jointVelocity, Eigen::VectorXd jointAcceleration, double fingertipSpeed) {
                         return TimingLimits{std::move(jointVelocity), std::move(jointAcceleration), fingertipSpeed};
                     }),
                     py::arg("joint_velocity"), py::arg("joint_acceleration"), py::arg("fingertip_speed"),
                     "joint_velocity, joint_acceleration: (dof,) limits (rad/s, rad/s^2); fingertip_speed: the cap (m/s).")
                .def_readonly("joint_velocity", &TimingLimits::jointVelocity, "(dof,) rad/s.")
                .def_readonly("joint_acceleration", &TimingLimits::jointAcceleration, "(dof,) rad/s^2.")
                .def_readonly("fingertip_speed", &TimingLimits::fingertipSpeed, "m/s.");
            module.attr("NEAR_TABLE_M") = kNearTableM;
            module.def(
                "time_path",
                [](const Eigen::MatrixXd &path, const Eigen::MatrixXd &tips, const std::vector<bool> &capped, const TimingLimits &limits) {
                    TimedPath timed;
                    {
                        py::gil_scoped_release release;
                        timed = timePath(path, tips, capped, limits);
                    }
                    return timedSegment(timed);
                },
                py::arg("path"), py::arg("tips"), py::arg("capped"), py::arg("limits"),
                "Time one dense path from rest to rest (timing.hpp). Releases the GIL.\n\n"
                "path: (M, dof) waypoints; tips: (M, 3) fingertip positions; capped: M flags, where the fingertip cap "
                "applies (an interval is capped when either end is); limits: TimingLimits.\n"
                "Returns {'time_from_start', 'velocities', 'accelerations'}. Raises ValueError for malformed input, "
                "RuntimeError when no rest-to-rest parameterization exists.");
            module.def(
                "time_plan",
                [](const RobotModel &robot, const Eigen::MatrixXd &trajectory, const Eigen::MatrixXd &trajectoryTips,
                   const Eigen::MatrixXd &approach, double objectTopZ, const TimingLimits &limits) {
                    PlanTiming timing;
                    {
                        py::gil_scoped_release release;
                        timing = timePlan(robot, trajectory, trajectoryTips, approach, objectTopZ, limits);
                    }
                    return timingDict(timing);
                },
                py::arg("robot"), py::arg("trajectory"), py::arg("trajectory_tips"), py::arg("approach"), py::arg("object_top_z"),
                py::arg("limits"),
                "Time-optimal rest-to-rest profiles of a plan's slide and approach (TOPP-RA, timing.hpp). Releases the GIL.\n\n"
                "robot: the plan's RobotModel (its fingertip frame gives the approach's fingertip positions); trajectory: "
                "(M, dof) slide, capped throughout; trajectory_tips: (M, 3) fingertip positions along it; approach: (K, dof) "
                "move to the grasp, capped within NEAR_TABLE_M of object_top_z (m); limits: TimingLimits.\n"
                "Returns {'trajectory': segment, 'approach': segment}, each {'time_from_start': (M,), 'velocities': (M, dof), "
                "'accelerations': (M, dof)}. Raises ValueError for malformed input, RuntimeError when no rest-to-rest "
                "parameterization exists.");
        }

        /// plan_sliding (Algorithm 1) and the benchmark peer ompl_projected_connect.
        void bindPlanning(py::module_ &module)
        {
            module.def("plan_sliding", &plan, py::arg("robot"), py::arg("table"), py::arg("obstacles"), py::arg("contact_links"),
                       py::arg("object_points"), py::arg("object_com_xy"), py::arg("params"), py::arg("seed"),
                       py::arg("time_limit"), py::arg("grasp_link"), py::arg("grasp_offset") = Eigen::Matrix4d::Identity(),
                       py::arg("grasp_map") = nullptr, py::arg("timing") = py::none(), py::arg("start_config") = py::none(),
                       "Plan a pre-grasp sliding motion (Algorithm 1). Releases the GIL; Ctrl-C raises KeyboardInterrupt.\n\n"
                       "robot: the shared, immutable RobotModel; table: SupportSurface Q; obstacles: BoxObstacle list; "
                       "contact_links: links that may touch table and object while sliding; object_points: (N, 3) top-surface "
                       "cloud P_o, world frame; object_com_xy: centre of mass; params: PlannerParams; seed: RNG seed; "
                       "time_limit: seconds; grasp_link, grasp_offset (4x4): the grasp frame H_g = link * offset; grasp_map: "
                       "a GraspMap shared with other plans of the same robot, table, grasp frame, thickness and grasp "
                       "parameters (None: one of its own; the plan is the same either way); timing: TimingLimits to time "
                       "a solved plan with (time_plan), still without the GIL, or None; start_config: (dof,) configuration "
                       "the arm is in, in contact with the object (planning from a state: the plan starts there), or None.\n"
                       "Raises InvalidStartConfig (a ValueError) saying why a start_config is not a valid sliding state with "
                       "its fingertip on the object; ValueError for other bad input (object off the table or degenerate, bad parameters, non-positive "
                       "time limit, unknown grasp link, a grasp map made for other geometry, malformed timing limits); "
                       "RuntimeError when a solved path has no rest-to-rest time parameterization.");

            module.def(
                "ompl_projected_connect",
                [](std::shared_ptr<const RobotModel> robot, const SupportSurface &table, const std::vector<Obstacle> &obstacles,
                   const std::vector<std::string> &contactLinks, const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints,
                   const Eigen::Vector2d &objectCom, const PlannerParams &params, double timeLimit, const std::string &graspLink,
                   const Eigen::Matrix4d &graspOffset, const Eigen::VectorXd &start, const Eigen::VectorXd &goal) {
                    params.validate();
                    const auto task = makeTask(robot, table, obstacles, contactLinks, objectPoints, objectCom, graspLink,
                                               graspOffset, timeLimit, false);
                    PeerResult result;
                    {
                        py::gil_scoped_release release;
                        result = connectWithOmplProjection(task, params, start, goal,
                                                           ompl::base::timedPlannerTerminationCondition(timeLimit));
                    }
                    return py::make_tuple(result.solved, result.seconds, result.states);
                },
                py::arg("robot"), py::arg("table"), py::arg("obstacles"), py::arg("contact_links"), py::arg("object_points"),
                py::arg("object_com_xy"), py::arg("params"), py::arg("time_limit"), py::arg("grasp_link"),
                py::arg("grasp_offset"), py::arg("start"), py::arg("goal"),
                "Benchmark peer: connect a valid start/goal pair (start, goal: configurations) with OMPL's "
                "ProjectedStateSpace + RRTConnect on the same constraint and validity (the other arguments as for "
                "plan_sliding). Returns (solved, seconds, path states).");
        }
    }  // namespace

    void bindPlanner(py::module_ &module)
    {
        bindParams(module);
        bindResult(module);
        bindGraspMap(module);
        bindTiming(module);
        bindPlanning(module);
    }
}  // namespace slideplan::bindings
