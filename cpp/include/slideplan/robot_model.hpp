/// \file robot_model.hpp
/// The arm: a URDF (urdfdom) read into an immutable kinematic tree; Gamma(phi) (forward kinematics to
/// the contact frame), its geometric Jacobian, and Gamma~(omega) (inverse kinematics, written here:
/// docs/design.md 7 forbids KDL's SVD-based solvers). KDL is kept as the reference the kernel is tested
/// against (`referenceFramePose`, `referenceJacobian`).
///
/// Thread safety: every const member may be called from any number of threads at once. (KDL's
/// `Joint::pose` caches its last result in mutable members, so a KDL chain shared between threads
/// returns wrong poses; the hot path therefore never calls KDL.)
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <kdl/segment.hpp>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace fcl
{
    template <typename S>
    class CollisionGeometry;
}

namespace slideplan
{
    /// Most movable joints a chain may have: per-call Jacobians and joint vectors of the hot path live
    /// on the stack with this capacity instead of on the heap.
    constexpr int kMaxJoints = 32;
    using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints>;
    using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints, 1>;
    /// Joint values from any contiguous vector (VectorXd, JointVector, an OMPL state's Map), not copied.
    using JointsRef = Eigen::Ref<const Eigen::VectorXd>;

    /// A triangle mesh in its link's collision frame (already scaled).
    struct TriangleMesh
    {
        std::vector<Eigen::Vector3d> vertices;
        std::vector<Eigen::Vector3i> triangles;
    };

    /// One collision shape of a link, posed in the link frame.
    struct LinkShape
    {
        enum class Type
        {
            Box,
            Cylinder,
            Sphere,
            Mesh
        };
        Type type;
        Eigen::Vector3d size;  ///< box: full extents; cylinder: (radius, length, 0); sphere: (radius, 0, 0)
        Eigen::Isometry3d origin{Eigen::Isometry3d::Identity()};
        std::shared_ptr<const TriangleMesh> mesh;  ///< Mesh only: the convex hull of the file's triangles
        /// Mesh only: the file's triangles when the link is part of the hand (moved by the chain's last
        /// joint) and the hull is more than kConcaveHullRatio times their volume (checked as an FCL BVH,
        /// exact but slower), else null (checked as the hull).
        std::shared_ptr<const TriangleMesh> surface;
        double hullRatio{1.0};                     ///< Mesh only: the hull's volume over the mesh's
        std::string meshFile;                      ///< Mesh only: the resolved file, for messages
        /// The shape for FCL (linkGeometry), built once when the robot loads: a hand mesh's BVH takes
        /// a tenth of a second to build. CollisionWorlds share it, except a BVH, which each copies.
        std::shared_ptr<fcl::CollisionGeometry<double>> geometry;
    };

    /// A link of the robot tree, its parent joint and its collision shapes.
    struct RobotLink
    {
        enum class JointType
        {
            Fixed,
            Revolute,
            Prismatic
        };
        std::string name;
        int parent{-1};            ///< index into RobotModel::links(), -1 for the root
        std::string jointName;     ///< the parent joint ("" for the root)
        JointType jointType{JointType::Fixed};
        Eigen::Isometry3d origin{Eigen::Isometry3d::Identity()};  ///< parent frame -> joint frame
        Eigen::Vector3d axis{Eigen::Vector3d::UnitZ()};           ///< unit axis in the joint frame
        /// Joint value = multiplier * q(jointIndex) + offset; jointIndex -1: the constant `offset`
        /// (fixed_joints, mimic joints of held joints, unlisted joints off the chain).
        int jointIndex{-1};
        double multiplier{1.0};
        double offset{0.0};
        std::vector<LinkShape> shapes;
        KDL::Segment segment;      ///< the same joint for KDL (reference computations only)
    };

    /// What a scene says about its robot (docs/design.md 5, [robot] and [hand]).
    struct RobotSpec
    {
        std::string urdf;                   ///< URDF text
        std::string source{"<urdf>"};       ///< file name for messages
        std::string directory;              ///< where relative mesh file names resolve ("" : the working directory)
        std::vector<std::string> packageDirs;  ///< package://NAME/... resolves to DIR/NAME/... or DIR/... if DIR is named NAME
        Eigen::Isometry3d basePose{Eigen::Isometry3d::Identity()};  ///< world pose of the URDF root link
        std::string baseLink;               ///< root of the planned chain ("": the URDF root)
        std::string tipLink;                ///< contact frame F = tipLink * tipOffset
        Eigen::Isometry3d tipOffset{Eigen::Isometry3d::Identity()};
        std::map<std::string, double> fixedJoints;  ///< joints held at a value (off the planned chain)
    };

    /// Options of the damped-least-squares inverse kinematics.
    struct IkOptions
    {
        int maxIterations{100};          ///< per attempt
        int maxAttempts{50};             ///< the seed, then random restarts
        double positionTolerance{1e-8};  ///< metres
        double orientationTolerance{1e-8};  ///< radians
        /// Asked before every restart: true ends the search unsolved (a planner's time limit, so that
        /// many attempts per call cannot overrun it). Empty: never.
        std::function<bool()> stop;
        /// Asked of every converged solution: false goes on with the next restart (a solution must
        /// also do what the caller needs, e.g. a grasp that can then lift). Empty: any.
        std::function<bool(const Eigen::VectorXd &)> accept;
        /// A restart whose pose error (metres + radians) is still above abandonError after abandonAfter
        /// iterations ends there: few such restarts converge, and where most restarts fail (probing a
        /// pose that may be out of reach) they would take all maxIterations. 0: never.
        int abandonAfter{0};
        double abandonError{0.1};
        /// Rotation error tolerated about three axes before it counts (rad, a dead zone like the sliding
        /// constraint's bands): about the target frame's own x, y, z, or the world's with worldAxes. pi
        /// frees an axis. Zero (the default) asks for the target's orientation exactly. An arm with fewer
        /// than six joints reaches a grasp or a contact only with some rotation left free.
        Eigen::Vector3d rotationTolerance{Eigen::Vector3d::Zero()};
        bool worldAxes{false};
    };

    /// A serial arm (the chain from the base link to the tip link) inside a robot tree; every link is
    /// kept for collision checking. Immutable after construction.
    class RobotModel
    {
    public:
        /// \throws std::invalid_argument naming the file and the key for a malformed URDF, unknown
        ///         links or joints, a base link not upstream of the tip, bad fixed joint values, an
        ///         unreadable or unsupported mesh.
        explicit RobotModel(const RobotSpec &spec);

        /// The contact frame is `tipLink` itself, the chain starts at the URDF root.
        RobotModel(const std::string &urdfXml, const std::string &tipLink,
                   const Eigen::Isometry3d &basePose = Eigen::Isometry3d::Identity(),
                   const std::string &source = "<urdf>");

        static RobotModel fromFile(const std::string &path, const std::string &tipLink,
                                   const Eigen::Isometry3d &basePose = Eigen::Isometry3d::Identity());

        unsigned int dof() const { return static_cast<unsigned int>(jointNames_.size()); }
        const std::vector<std::string> &jointNames() const { return jointNames_; }
        const Eigen::VectorXd &lowerLimits() const { return lower_; }
        const Eigen::VectorXd &upperLimits() const { return upper_; }
        /// URDF velocity limits of the chain joints (0 where the URDF gives none).
        const Eigen::VectorXd &velocityLimits() const { return velocity_; }
        const std::string &tipLink() const { return tipLink_; }
        const Eigen::Isometry3d &tipOffset() const { return tip_.offset; }
        const Eigen::Isometry3d &basePose() const { return basePose_; }
        const std::string &source() const { return source_; }
        bool withinLimits(const JointsRef &q, double tolerance = 1e-9) const;

        /// Gamma(phi): world pose of the contact frame.
        Eigen::Isometry3d fk(const JointsRef &q) const;

        /// World pose of `link` * `offset` (e.g. the grasp frame).
        /// \throws std::invalid_argument for an unknown link.
        Eigen::Isometry3d framePose(const JointsRef &q, const std::string &link,
                                    const Eigen::Isometry3d &offset = Eigen::Isometry3d::Identity()) const;
        Eigen::Isometry3d linkPose(const JointsRef &q, const std::string &link) const
        {
            return framePose(q, link);
        }

        /// Geometric Jacobian of the contact frame in the world frame (rows: linear, angular velocity).
        Jacobian jacobian(const JointsRef &q) const;

        /// World poses of all links, indexed like links().
        void linkPoses(const JointsRef &q, std::vector<Eigen::Isometry3d> &poses) const;

        /// KDL's answers for the same frame and Jacobian: the reference the kernel is tested against.
        Eigen::Isometry3d referenceFramePose(const JointsRef &q, const std::string &link,
                                             const Eigen::Isometry3d &offset = Eigen::Isometry3d::Identity()) const;
        Eigen::Matrix<double, 6, Eigen::Dynamic> referenceJacobian(const JointsRef &q) const;

        /// Gamma~(omega): a configuration within the joint limits whose contact frame pose equals target.
        /// Damped least squares (Levenberg-Marquardt damping), starting from `seed`, then from random
        /// configurations drawn from `rng`. Returns false if no attempt converged.
        bool ik(const Eigen::Isometry3d &target, const Eigen::VectorXd &seed, std::mt19937_64 &rng,
                Eigen::VectorXd &solution, const IkOptions &options = IkOptions()) const;

        /// The same for `link` * `offset` (e.g. the grasp frame on the palm), a frame moved by every
        /// joint of the chain. \throws std::invalid_argument if the link is unknown or not moved by
        /// every chain joint.
        bool ikForLink(const std::string &link, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                       std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options = IkOptions(),
                       const Eigen::Isometry3d &offset = Eigen::Isometry3d::Identity()) const;

        Eigen::VectorXd randomConfiguration(std::mt19937_64 &rng) const;

        const std::vector<RobotLink> &links() const { return links_; }
        int linkIndex(const std::string &name) const;  ///< -1 if unknown
        /// Links from the root to `link` (root excluded, `link` included), root first.
        std::vector<int> pathTo(int link) const;

    private:
        /// A frame fixed to a link: the links moving it (root first) and the offset.
        struct FramePath
        {
            std::vector<int> links;
            Eigen::Isometry3d offset{Eigen::Isometry3d::Identity()};
        };
        FramePath framePath(const std::string &link, const Eigen::Isometry3d &offset) const;
        Eigen::Isometry3d pathPose(const FramePath &path, const JointsRef &q) const;
        /// With `pose`, also the frame's pose from the same pass (equal to pathPose's, bit for bit).
        Jacobian pathJacobian(const FramePath &path, const JointsRef &q, Eigen::Isometry3d *pose = nullptr) const;
        bool solveIk(const FramePath &path, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                     std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options) const;
        double jointValue(const RobotLink &link, const JointsRef &q) const
        {
            return link.jointIndex >= 0 ? link.multiplier * q(link.jointIndex) + link.offset : link.offset;
        }
        /// pose * (the joint's motion at `value`), in place.
        static void moveJoint(Eigen::Isometry3d &pose, const RobotLink &link, double value);

        std::string source_;
        std::string tipLink_;
        Eigen::Isometry3d basePose_;
        FramePath tip_;
        std::vector<std::string> jointNames_;
        Eigen::VectorXd lower_, upper_, velocity_;
        std::vector<bool> revolute_;    ///< per chain joint
        std::vector<RobotLink> links_;  ///< topological order: parents before children
    };

    /// 6-vector pose error (position, rotation vector) of `current` towards `target`, world frame.
    Eigen::Matrix<double, 6, 1> poseError(const Eigen::Isometry3d &current, const Eigen::Isometry3d &target);

}  // namespace slideplan
