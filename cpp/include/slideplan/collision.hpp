/// \file collision.hpp
/// Collision world (FCL): the robot's link primitives posed by FK, the table as a solid prism under
/// Q, obstacles (boxes, cylinders, prisms), and optionally the object as an obstacle (for the transfer to the grasp).
#pragma once

#include "slideplan/geometry.hpp"
#include "slideplan/object_motion.hpp"
#include "slideplan/obstacle.hpp"
#include "slideplan/robot_model.hpp"

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace slideplan
{
    /// A link shape as FCL geometry: a box, cylinder or sphere; a mesh as its convex hull, or as a BVH
    /// of its triangles where LinkShape::surface holds them.
    std::shared_ptr<fcl::CollisionGeometry<double>> linkGeometry(const LinkShape &shape);

    /// Whether the contacting finger may penetrate the table and the object. During sliding it may:
    /// the virtual penetration stands for the finger's passive reconfiguration (docs/design.md 3).
    enum class ContactMode
    {
        Sliding,  ///< contact links excluded from table and object checks
        Free      ///< every link checked against everything
    };

    class CollisionWorld
    {
    public:
        /// \param contactLinks  links of the contacting finger (excluded from table/object in Sliding mode)
        /// \param tableDepth    the table is a solid prism from its top down by this much
        /// \throws std::invalid_argument for an unknown contact link or a bad obstacle.
        CollisionWorld(std::shared_ptr<const RobotModel> robot, const SupportSurface &table,
                       const std::vector<Obstacle> &obstacles, const std::vector<std::string> &contactLinks,
                       double tableDepth = 0.75);
        ~CollisionWorld();
        /// Another world with the same robot, table, obstacles and object (sharing their immutable
        /// geometry), without measuring the self-collision pairs again: one per user of a task.
        std::unique_ptr<CollisionWorld> clone() const;
        CollisionWorld(const CollisionWorld &) = delete;
        CollisionWorld &operator=(const CollisionWorld &) = delete;

        /// True if configuration q is free of collisions (self, table, obstacles, object if set).
        /// Not thread-safe: one world per planning thread.
        bool isValid(const JointsRef &q, ContactMode mode = ContactMode::Sliding) const;

        /// True if the robot at q is clear of the object set by setObject (nothing else is checked): for
        /// configurations already known valid without it. \throws std::logic_error if no object is set.
        bool objectFree(const JointsRef &q, ContactMode mode = ContactMode::Sliding) const;

        /// True if the links rigid with `link` (moved by no joint that does not also move it: for the grasp
        /// link, the hand past its last joint) are clear of the table and the obstacles with `link` at world
        /// pose `pose`, in any mode. Needs no configuration, so a grasp pose can be screened before its IK;
        /// the rest of the robot and the object are not checked. Not thread-safe, as isValid.
        /// \throws std::invalid_argument for an unknown link.
        bool rigidFree(const std::string &link, const Eigen::Isometry3d &pose) const { return rigidCollision(link, pose).empty(); }
        /// As rigidFree, naming what collides: "link-obstacle" (or "link-table") for the first hit, empty if clear.
        std::string rigidCollision(const std::string &link, const Eigen::Isometry3d &pose) const;

        /// The colliding pairs at q, by link or obstacle name: for diagnostics and the verifier.
        std::vector<std::pair<std::string, std::string>> collisions(const JointsRef &q,
                                                                    ContactMode mode = ContactMode::Sliding) const;

        /// For each row of `points`, whether a link at q crosses the line of sight to it from `eye` (a
        /// capsule of `radius` around the segment): what a camera at `eye` cannot see of the points with the
        /// robot there. Only the robot is checked. Not thread-safe, as isValid.
        /// \throws std::invalid_argument for a wrong-sized or non-finite q, non-finite eye or points, a
        /// radius not > 0, or a point at the eye.
        std::vector<bool> hiddenLines(const JointsRef &q, const Eigen::Vector3d &eye,
                                      const Eigen::Matrix<double, Eigen::Dynamic, 3> &points, double radius) const;

        /// Put the object in the world as a prism over the convex hull of `outlineXY` between the table
        /// top and `topZ`.
        void setObject(const std::vector<Eigen::Vector2d> &outlineXY, double topZ);
        /// Move the object set by setObject rigidly in the table plane: its outline becomes
        /// motion.apply(outline). Far cheaper than setObject for an object sliding along a path.
        /// \throws std::logic_error if no object is set.
        void moveObject(const PlanarMotion &motion);
        void clearObject();

        /// Link pairs checked for self-collision (those not adjacent and not always in contact).
        std::size_t selfPairCount() const;
        /// Pairs of links (by name, each once) left unchecked for being in contact in almost every random
        /// configuration: overlapping collision shapes, or a held joint value that puts two parts together.
        std::vector<std::pair<std::string, std::string>> alwaysInContact() const;
        const RobotModel &robot() const { return *robot_; }

    private:
        struct Impl;
        CollisionWorld(std::shared_ptr<const RobotModel> robot, std::unique_ptr<Impl> impl);
        /// `objectOnly`: the robot against the object alone.
        bool check(const JointsRef &q, ContactMode mode, std::vector<std::pair<std::string, std::string>> *report,
                   bool objectOnly = false) const;
        std::shared_ptr<const RobotModel> robot_;
        std::unique_ptr<Impl> impl_;
    };

}  // namespace slideplan
