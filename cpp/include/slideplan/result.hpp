/// \file result.hpp
/// What a planning run returns: the sliding trajectory, the object motion (Eq. 2), the grasp and
/// the statistics that the experiments of section V report.
#pragma once

#include "slideplan/object_motion.hpp"
#include "slideplan/timing.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace slideplan
{
    struct PlanStats
    {
        long iterations{0};
        int startRoots{0};
        int goalRoots{0};
        long connections{0};    ///< times a start tree and a goal tree met (each asks IsPairValid)
        long pairsChecked{0};   ///< IsPairValid evaluations (fewer than connections with verdict caching)
        long pairsRejected{0};
        std::map<std::string, long> rejections;  ///< rejected pairs by reason (IV-C.1 conditions)
        long nodes{0};          ///< tree nodes over both forests
        long rootSamples{0};    ///< root sampling attempts (successful or not)
        double precomputeTime{0.0};  ///< baselines: time to find their fixed roots (s), included in planningTime
        double setupTime{0.0};  ///< before the search: checks of the input, the collision worlds (s), included in planningTime
        double fingertipPath{0.0};   ///< length of the fingertip's path over the table (m) of a solved plan
        double comMargin{0.0};       ///< distance of the final centre of mass inside the table (m)
        double yawTravel{0.0};       ///< total |change| of the contact frame's yaw along it (rad): the object's turning
    };

    struct PlanResult
    {
        std::string status{"timeout"};  ///< "solved" | "timeout"
        std::string planner;            ///< "slideplan" | "cbirrt" | "cbirrt2"
        double planningTime{0.0};       ///< seconds, precomputation included
        Eigen::VectorXd startConfig, goalConfig;
        std::vector<Eigen::VectorXd> trajectory;          ///< dense, start to goal
        std::vector<Eigen::Isometry3d> fingertipPoses;    ///< contact frame F per waypoint
        PlanarMotion objectMotion;
        double overhang{0.0};                             ///< u of the final object pose (m)
        Eigen::Isometry3d graspPose{Eigen::Isometry3d::Identity()};  ///< H_g (grasp frame)
        Eigen::VectorXd graspConfig;
        std::vector<Eigen::VectorXd> approach;            ///< dense, goal config to grasp config
        PlanStats stats;
        std::optional<PlanTiming> timing;                 ///< timePlan's profile, when the caller asks for one
    };

}  // namespace slideplan
