/// \file task.hpp
/// One sliding problem: robot, table Q, obstacles and the thin object's top-surface cloud P_o.
#pragma once

#include "slideplan/collision.hpp"
#include "slideplan/geometry.hpp"
#include "slideplan/object_motion.hpp"
#include "slideplan/robot_model.hpp"

#include <memory>
#include <string>
#include <vector>

namespace slideplan
{
    struct SlidingTask
    {
        std::shared_ptr<const RobotModel> robot;
        std::shared_ptr<const SupportSurface> table;
        std::vector<Obstacle> obstacles;
        std::vector<std::string> contactLinks;  ///< excluded from table/object collisions while sliding
        std::string graspLink;   ///< H_g = graspLink * graspOffset: z = approach, y = the fingers' closing axis
        Eigen::Isometry3d graspOffset{Eigen::Isometry3d::Identity()};
        Polygon2 objectXY;       ///< P_o projected on the table plane, world frame
        double surfaceZ{0.0};    ///< z_s: top of the object = table height + thickness
        Eigen::Vector2d objectCom{Eigen::Vector2d::Zero()};  ///< centre of mass (uniform thin plate)

        /// Build from the N x 3 top-surface cloud; z_s is the mean z of the cloud.
        /// \throws std::invalid_argument for an unknown grasp link, an empty or non-finite cloud, a cloud below the table top,
        ///         an object not wholly on the table (unless `mayOverhang`: planning from a state, where
        ///         the object may already overhang an edge), a centre of mass off the table, or a degenerate
        ///         footprint (collinear or coincident points), an obstacle into the table top or off the
        ///         table, or an obstacle overlapping the object where it lies.
        static SlidingTask make(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                                std::vector<Obstacle> obstacles, std::vector<std::string> contactLinks,
                                std::string graspLink, const Eigen::Isometry3d &graspOffset,
                                const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints,
                                const Eigen::Vector2d &objectCom, bool mayOverhang = false);

        double thickness() const { return surfaceZ - table->height(); }

        /// Whether the object, moved by `motion` (Eq. 2) from where it lies, overlaps no obstacle that
        /// reaches down to it: its fixed-resolution footprint and hull vertices against the obstacles'
        /// footprints (its outline, not its convex hull, so a crescent may wrap around a can).
        bool objectClear(const PlanarMotion &motion) const { return overlappedObstacle(motion) < 0; }
        /// Whether the object's centre of mass, moved by `motion`, lies on the table.
        bool comOnTable(const PlanarMotion &motion) const { return table->contains(motion.apply(objectCom)); }
        /// The index in `obstacles` of the first obstacle the moved object overlaps (as objectClear), or -1.
        int overlappedObstacle(const PlanarMotion &motion) const;
        double extent{0.0};      ///< largest distance between two points of P_o (over its convex hull)
        std::vector<Eigen::Vector2d> hullXY;  ///< convex hull of P_o, counter-clockwise

        /// P_o at a fixed resolution, for the many pair checks: the mean of the points in each
        /// kFootprintCell-sided grid cell and how many points it stands for. Its size is bounded by the
        /// object's area, not by the sensor's resolution (beyond the paper; the accepted pair is
        /// re-checked on P_o itself).
        static constexpr double kFootprintCell = 0.002;  // m
        Polygon2 footprintXY;
        Eigen::VectorXd footprintWeight;
    };

}  // namespace slideplan
