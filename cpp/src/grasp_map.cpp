#include "slideplan/grasp_map.hpp"

#include <cmath>
#include <stdexcept>

namespace slideplan
{
    Eigen::Isometry3d sideGraspPose(const Eigen::Vector2d &point, const EdgeQuery &edge, double z)
    {
        const Eigen::Vector3d approach(-edge.outwardNormal.x(), -edge.outwardNormal.y(), 0.0);
        const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.linear().col(0) = up.cross(approach);
        pose.linear().col(1) = up;
        pose.linear().col(2) = approach;
        pose.translation() << point, z;
        return pose;
    }

    bool liftableGraspIk(const SlidingTask &task, const PlannerParams &params, const Eigen::Isometry3d &grasp,
                         const Eigen::VectorXd &seed, int attempts, std::mt19937_64 &rng, Eigen::VectorXd &solution,
                         int abandonAfter)
    {
        const RobotModel &robot = *task.robot;
        Eigen::Isometry3d lifted = grasp;
        lifted.translation().z() += params.graspLift;
        IkOptions options;
        options.maxAttempts = attempts;
        options.abandonAfter = abandonAfter;
        // Asked of every solution, so that the restarts look for another posture rather than give up.
        options.accept = [&](const Eigen::VectorXd &q) {
            IkOptions near;
            near.maxAttempts = 1;
            Eigen::VectorXd raised;
            return robot.ikForLink(task.graspLink, lifted, q, rng, raised, near, task.graspOffset);
        };
        return robot.ikForLink(task.graspLink, grasp, seed, rng, solution, options, task.graspOffset);
    }

    GraspMap::GraspMap(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                       std::string graspLink, const Eigen::Isometry3d &graspOffset, double thickness,
                       const PlannerParams &params)
      : thickness_(micrometres(thickness)), params_(params)
    {
        if (!robot || !table || !std::isfinite(thickness) || thickness < 0.0)
            throw std::invalid_argument("a grasp map needs a robot, a table and a thickness >= 0");
        if (robot->linkIndex(graspLink) < 0)  // as SlidingTask::make says it
            throw std::invalid_argument("[hand] grasp_link '" + graspLink + "' is not a link of the robot");
        geometry_.robot = std::move(robot);
        geometry_.table = std::move(table);
        geometry_.graspLink = std::move(graspLink);
        geometry_.graspOffset = graspOffset;
    }

    GraspMap::GraspMap(const SlidingTask &task, const PlannerParams &params)
      : GraspMap(task.robot, task.table, task.graspLink, task.graspOffset, task.thickness(), params)
    {
    }

    std::pair<int, long> GraspMap::stretch(const EdgeQuery &edge) const
    {
        const Eigen::Vector2d start = geometry_.table->vertices().row(edge.edge).transpose();
        return {edge.edge, static_cast<long>(std::floor((edge.closest - start).norm() / kStretch))};
    }

    bool GraspMap::reachable(const EdgeQuery &edge) const
    {
        return lookUp(edge).size() > 0;
    }

    Eigen::VectorXd GraspMap::graspSeed(const EdgeQuery &edge) const
    {
        return lookUp(edge);
    }

    Eigen::VectorXd GraspMap::lookUp(const EdgeQuery &edge) const
    {
        const std::pair<int, long> key = stretch(edge);
        {
            const std::lock_guard<std::mutex> lock(mutex_);
            if (const auto known = known_.find(key); known != known_.end())
                return known->second;
        }
        // Probed without the lock: two plans may probe the same stretch at once, with the same answer.
        Eigen::VectorXd answer = probe(key);
        const std::lock_guard<std::mutex> lock(mutex_);
        known_.emplace(key, answer);
        return answer;
    }

    Eigen::VectorXd GraspMap::probe(const std::pair<int, long> &stretch) const
    {
        // Side grasps at table height are a thin part of the workspace: about one restart in 5 succeeds,
        // and an unreachable stretch costs every restart. So a restart still 0.1 (m + rad) off after
        // kAbandon iterations is given up (WAM + T42, four tables: 95% of the restarts that fail, 7% of
        // those that would converge), which pays for twice the restarts: against 20 restarts of 100
        // iterations, the maps of the four tables lose no reachable stretch, gain 8 that were missed, and
        // cost 2.2-2.9x less (the triangle table's 154 stretches: 405 -> 139 ms).
        constexpr int kAbandon = 30;
        const int restarts = params_.graspFlip ? 20 : 40;
        const SupportSurface &table = *geometry_.table;
        const int next = (stretch.first + 1) % static_cast<int>(table.vertices().rows());
        const Eigen::Vector2d a = table.vertices().row(stretch.first).transpose();
        const Eigen::Vector2d b = table.vertices().row(next).transpose();
        const Eigen::Vector2d direction = (b - a).normalized();
        EdgeQuery edge;
        edge.edge = stretch.first;
        edge.closest = a + std::min((stretch.second + 0.5) * kStretch, (b - a).norm()) * direction;
        edge.outwardNormal = Eigen::Vector2d(direction.y(), -direction.x());  // as SupportSurface::closestEdge
        // Where a grasp of an object pushed just far enough over this edge would be.
        const double beyond = std::max(params_.graspStandoff, 0.5 * params_.uStar);
        const double z = table.height() + 0.5 * thickness_;
        Eigen::Isometry3d grasp = sideGraspPose(edge.closest + beyond * edge.outwardNormal, edge, z);
        std::mt19937_64 rng(0x5eed0000u + 1000003u * static_cast<std::uint64_t>(stretch.first) +
                            static_cast<std::uint64_t>(stretch.second));
        Eigen::VectorXd solution;
        if (liftableGraspIk(geometry_, params_, grasp, Eigen::VectorXd(), restarts, rng, solution, kAbandon))
            return solution;
        if (!params_.graspFlip)
            return {};
        grasp.linear() = grasp.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        if (liftableGraspIk(geometry_, params_, grasp, Eigen::VectorXd(), restarts, rng, solution, kAbandon))
            return solution;
        return {};
    }

    bool GraspMap::fits(const SlidingTask &task, const PlannerParams &params) const
    {
        const SupportSurface &mine = *geometry_.table, &theirs = *task.table;
        return task.robot == geometry_.robot && task.graspLink == geometry_.graspLink &&
               task.graspOffset.isApprox(geometry_.graspOffset, 0.0) &&
               std::abs(micrometres(task.thickness()) - thickness_) < 1.5e-6 &&  // rounding may straddle
               theirs.height() == mine.height() && theirs.vertices().rows() == mine.vertices().rows() &&
               theirs.vertices() == mine.vertices() && params.graspStandoff == params_.graspStandoff &&
               params.uStar == params_.uStar && params.graspLift == params_.graspLift && params.graspFlip == params_.graspFlip;
    }

    std::size_t GraspMap::probed() const
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        return known_.size();
    }

}  // namespace slideplan
