#include "slideplan/paired_goal.hpp"

#include "slideplan/contact_frame.hpp"

#include <algorithm>
#include <cmath>

namespace slideplan
{
    bool pairedGoalTarget(const SlidingTask &task, const PlannerParams &params, const PairValidator &validator,
                          const Eigen::Isometry3d &startTip, std::mt19937_64 &rng,
                          Eigen::Isometry3d &target)
    {
        const Polygon2 &vertices = task.table->vertices();  // counter-clockwise: the outward normal is on the right
        const int edges = task.table->size();
        std::vector<double> lengths(static_cast<std::size_t>(edges));
        for (int i = 0; i < edges; ++i)
            lengths[static_cast<std::size_t>(i)] = (vertices.row((i + 1) % edges) - vertices.row(i)).norm();
        std::discrete_distribution<int> edge(lengths.begin(), lengths.end());
        std::uniform_real_distribution<double> unit(0.0, 1.0), depth(params.dzMin, params.dzMax);
        const double maxYaw = std::min(params.maxObjectYaw, M_PI);

        // Cheap draws (footprint geometry only) per goal root. Where few stretches admit a side grasp (the
        // triangle table: 7 of 154), 16 left most goal-root attempts empty and the search ran 90 iterations
        // a plan instead of 34 with 48.
        constexpr int kTries = 48;
        for (int attempt = 0; attempt < kTries; ++attempt)
        {
            const int i = edge(rng);
            const Eigen::Vector2d a = vertices.row(i).transpose(), b = vertices.row((i + 1) % edges).transpose();
            const Eigen::Vector2d along = (b - a).normalized(), outward(along.y(), -along.x());
            PlanarMotion motion;
            motion.yaw = maxYaw * (2.0 * unit(rng) - 1.0);
            const Eigen::Rotation2Dd turn(motion.yaw);
            // How far the turned object reaches beyond its centre of mass towards the edge.
            double reach = 0.0;
            for (const Eigen::Vector2d &vertex : task.hullXY)
                reach = std::max(reach, outward.dot(turn * (vertex - task.objectCom)));
            const double widest = reach - params.comMargin;
            if (widest < params.uStar)
                continue;
            const double overhang = params.uStar + unit(rng) * (widest - params.uStar);
            const Eigen::Vector2d com = a + unit(rng) * (b - a) + (overhang - reach) * outward;
            const Eigen::Vector2d offset = com - turn * task.objectCom;
            motion.x = offset.x();
            motion.y = offset.y();
            // The fingertip first: one point, where the overhang classifies the whole footprint.
            const Eigen::Vector2d contact = motion.apply(startTip.translation().head<2>());
            const double inside = task.table->signedDistance(contact);
            if (inside <= 0.0 || inside > params.dGoal)
                continue;
            // A turn the slide cannot make at max_yaw_rate along the straight line needs a detour the
            // trees rarely find: under the paper's any-turn pairs, most triangle-table goal roots were such.
            if (params.maxYawRate > 0.0 &&
                std::abs(motion.yaw) > params.maxYawRate * (contact - startTip.translation().head<2>()).norm())
                continue;
            const Overhang result = validator.overhang(motion);
            if (!validator.graspable(result) || !result.comInside || !result.supported)
                continue;
            // Last, as they may cost a grasp IK: a side grasp reachable where this pose would be grasped, with
            // the hand clear of the table there.
            if (!validator.graspReachableNear(result.graspPoint) || !validator.graspClear(result))
                continue;
            const double yaw = contactAngles(startTip.linear()).yaw + motion.yaw;
            target = Eigen::Isometry3d::Identity();
            target.linear() = contactRotation(yaw, params.beta0);
            target.translation() << contact, task.surfaceZ - depth(rng);
            return true;
        }
        return false;
    }

}  // namespace slideplan
