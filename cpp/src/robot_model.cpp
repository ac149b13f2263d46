#include "slideplan/robot_model.hpp"

#include "slideplan/collision.hpp"
#include "slideplan/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <console_bridge/console.h>
#include <fstream>
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <urdf_parser/urdf_parser.h>

namespace slideplan
{
    namespace
    {
        /// Drops every link's hold on its children when the model goes: a URDF whose joints form a loop
        /// gives links that own each other, which would never be freed.
        struct TreeRelease
        {
            urdf::ModelInterfaceSharedPtr model;
            ~TreeRelease()
            {
                for (const auto &[name, link] : model->links_)
                {
                    link->child_links.clear();
                    link->child_joints.clear();
                }
            }
        };

        /// urdfdom reports through console_bridge, to stderr by default. Installed once for the process:
        /// what urdfdom says while a thread of ours parses goes to that thread's list (and becomes the
        /// reason in our one error line); what anyone else logs goes where it went before.
        class UrdfdomMessages : public console_bridge::OutputHandler
        {
        public:
            /// Collects the errors logged in this thread while it lives.
            class Capture
            {
            public:
                Capture()
                {
                    instance();
                    sink_ = &errors_;
                }
                ~Capture() { sink_ = nullptr; }
                Capture(const Capture &) = delete;
                Capture &operator=(const Capture &) = delete;

                /// The errors joined by "; ", empty if there were none.
                std::string reason() const
                {
                    std::string joined;
                    for (const std::string &error : errors_)
                        joined += (joined.empty() ? "" : "; ") + error;
                    return joined;
                }

            private:
                std::vector<std::string> errors_;
            };

            void log(const std::string &text, console_bridge::LogLevel level, const char *filename, int line) override
            {
                if (sink_ != nullptr)
                {
                    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR)
                        sink_->push_back(text);
                }
                else if (previous_ != nullptr)
                    previous_->log(text, level, filename, line);
            }

        private:
            UrdfdomMessages() : previous_(console_bridge::getOutputHandler()) { console_bridge::useOutputHandler(this); }

            static UrdfdomMessages &instance()
            {
                static UrdfdomMessages *const handler = new UrdfdomMessages;  // never destroyed: logging may outlive statics
                return *handler;
            }

            console_bridge::OutputHandler *previous_;
            static thread_local std::vector<std::string> *sink_;
        };

        thread_local std::vector<std::string> *UrdfdomMessages::sink_ = nullptr;

        KDL::Frame toKdl(const urdf::Pose &pose)
        {
            double x, y, z, w;
            pose.rotation.getQuaternion(x, y, z, w);
            return {KDL::Rotation::Quaternion(x, y, z, w), KDL::Vector(pose.position.x, pose.position.y, pose.position.z)};
        }

        Eigen::Isometry3d toEigen(const KDL::Frame &frame)
        {
            Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
            for (int r = 0; r < 3; ++r)
            {
                out.translation()(r) = frame.p(r);
                for (int c = 0; c < 3; ++c)
                    out.linear()(r, c) = frame.M(r, c);
            }
            return out;
        }

        Eigen::Isometry3d toEigen(const urdf::Pose &pose)
        {
            return toEigen(toKdl(pose));
        }

        bool movable(const urdf::Joint &joint)
        {
            return joint.type == urdf::Joint::REVOLUTE || joint.type == urdf::Joint::CONTINUOUS ||
                   joint.type == urdf::Joint::PRISMATIC;
        }

        /// The KDL joint for a URDF joint, expressed in the parent link frame as kdl_parser does.
        KDL::Joint toKdlJoint(const std::string &source, const urdf::Joint &joint)
        {
            const KDL::Frame origin = toKdl(joint.parent_to_joint_origin_transform);
            const KDL::Vector axis(joint.axis.x, joint.axis.y, joint.axis.z);
            switch (joint.type)
            {
                case urdf::Joint::REVOLUTE:
                case urdf::Joint::CONTINUOUS:
                    return KDL::Joint(joint.name, origin.p, origin.M * axis, KDL::Joint::RotAxis);
                case urdf::Joint::PRISMATIC:
                    return KDL::Joint(joint.name, origin.p, origin.M * axis, KDL::Joint::TransAxis);
                case urdf::Joint::FIXED:
                    return KDL::Joint(joint.name, KDL::Joint::None);
                default:
                    throw std::invalid_argument(source + ": joint '" + joint.name +
                                                "': only revolute, continuous, prismatic and fixed joints are supported");
            }
        }

        void addShape(const RobotSpec &spec, const std::string &link, const urdf::Collision &collision,
                      std::vector<LinkShape> &shapes)
        {
            if (!collision.geometry)
                return;
            LinkShape shape;
            shape.origin = toEigen(collision.origin);
            shape.size.setZero();
            switch (collision.geometry->type)
            {
                case urdf::Geometry::BOX:
                {
                    const auto &box = static_cast<const urdf::Box &>(*collision.geometry);
                    shape.type = LinkShape::Type::Box;
                    shape.size = Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z);
                    break;
                }
                case urdf::Geometry::CYLINDER:
                {
                    const auto &cylinder = static_cast<const urdf::Cylinder &>(*collision.geometry);
                    shape.type = LinkShape::Type::Cylinder;
                    shape.size = Eigen::Vector3d(cylinder.radius, cylinder.length, 0.0);
                    break;
                }
                case urdf::Geometry::SPHERE:
                {
                    shape.type = LinkShape::Type::Sphere;
                    shape.size.x() = static_cast<const urdf::Sphere &>(*collision.geometry).radius;
                    break;
                }
                case urdf::Geometry::MESH:
                {
                    const auto &mesh = static_cast<const urdf::Mesh &>(*collision.geometry);
                    const std::string where = spec.source + ": link '" + link + "' <mesh filename='" + mesh.filename + "'>";
                    const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
                    if (!scale.allFinite() || (scale.array() <= 0).any())
                        throw std::invalid_argument(where + ": scale must be positive");
                    shape.type = LinkShape::Type::Mesh;
                    shape.meshFile = resolveMeshUri(mesh.filename, spec.directory, spec.packageDirs, where);
                    const std::shared_ptr<const TriangleMesh> triangles = loadMesh(shape.meshFile, scale, where);
                    shape.mesh = convexHull(*triangles, where);
                    const double volume = meshVolume(*triangles);
                    shape.hullRatio = volume > 0.0 ? meshVolume(*shape.mesh) / volume : HUGE_VAL;
                    if (shape.hullRatio > kConcaveHullRatio)
                        shape.surface = triangles;
                    break;
                }
                default:
                    throw std::invalid_argument(spec.source + ": link '" + link + "': unknown collision geometry");
            }
            if (!shape.size.allFinite() || (shape.size.array() < 0).any() || !shape.origin.matrix().allFinite())
                throw std::invalid_argument(spec.source + ": link '" + link +
                                            "': collision geometry has a negative or non-finite size");
            shapes.push_back(std::move(shape));
        }
        /// The URDF parsed by urdfdom, refused on any error it logs: it drops a collision element it cannot
        /// read (e.g. radius="nan") with only a log line, so that a link would silently lose its geometry.
        urdf::ModelInterfaceSharedPtr parseUrdf(const RobotSpec &spec)
        {
            urdf::ModelInterfaceSharedPtr model;
            std::string reason;
            {
                UrdfdomMessages::Capture capture;
                try
                {
                    model = urdf::parseURDF(spec.urdf);
                }
                catch (const std::exception &error)
                {
                    throw std::invalid_argument(spec.source + ": malformed URDF: " + error.what());
                }
                reason = capture.reason();
            }
            if (!reason.empty())
                throw std::invalid_argument(spec.source + ": malformed URDF: " + reason);
            if (!model || !model->getRoot())
                throw std::invalid_argument(spec.source + ": malformed URDF (urdfdom could not parse it)");
            return model;
        }

        /// urdfdom accepts a link that is the child of two joints: walking the tree would then not end.
        void requireOneParent(const std::string &source, const urdf::ModelInterface &model)
        {
            std::map<std::string, std::string> parentJoint;
            for (const auto &[name, joint] : model.joints_)
                if (const auto [at, fresh] = parentJoint.emplace(joint->child_link_name, name); !fresh)
                    throw std::invalid_argument(source + ": malformed URDF: link '" + joint->child_link_name +
                                                "' is the child of two joints ('" + at->second + "', '" + name + "')");
        }

        /// The links in topological order, parents first, each with its joint and collision shapes.
        std::vector<RobotLink> readLinks(const RobotSpec &spec, const urdf::ModelInterface &model)
        {
            const std::string &source = spec.source;
            std::vector<RobotLink> links;
            std::map<std::string, int> index;
            std::vector<urdf::LinkConstSharedPtr> stack{model.getRoot()};
            while (!stack.empty())
            {
                const urdf::LinkConstSharedPtr link = stack.back();
                stack.pop_back();
                RobotLink entry;
                entry.name = link->name;
                if (link->parent_joint)
                {
                    const urdf::Joint &joint = *link->parent_joint;
                    entry.parent = index.at(link->getParent()->name);
                    entry.jointName = joint.name;
                    entry.segment = KDL::Segment(link->name, toKdlJoint(source, joint), toKdl(joint.parent_to_joint_origin_transform));
                    entry.origin = toEigen(joint.parent_to_joint_origin_transform);
                    if (movable(joint))
                    {
                        const Eigen::Vector3d axis(joint.axis.x, joint.axis.y, joint.axis.z);
                        if (!(axis.norm() > 1e-9) || !axis.allFinite())
                            throw std::invalid_argument(source + ": joint '" + joint.name + "' has a zero or non-finite axis");
                        entry.axis = axis.normalized();
                        entry.jointType = joint.type == urdf::Joint::PRISMATIC ? RobotLink::JointType::Prismatic
                                                                               : RobotLink::JointType::Revolute;
                    }
                }
                else
                    entry.segment = KDL::Segment(link->name, KDL::Joint(KDL::Joint::None));
                for (const auto &collision : link->collision_array)
                    addShape(spec, link->name, *collision, entry.shapes);
                if (link->collision_array.empty() && link->collision)
                    addShape(spec, link->name, *link->collision, entry.shapes);
                index[link->name] = static_cast<int>(links.size());
                links.push_back(std::move(entry));
                for (auto it = link->child_links.rbegin(); it != link->child_links.rend(); ++it)
                    stack.push_back(*it);
            }
            if (links.size() != model.links_.size())
                for (const auto &[name, link] : model.links_)
                    if (index.count(name) == 0)
                        throw std::invalid_argument(source + ": malformed URDF: link '" + name +
                                                    "' is not connected to the root (its joints form a loop)");
            return links;
        }

        /// A movable joint's limits; a continuous joint turns one turn each way, which suffices.
        std::pair<double, double> jointLimits(const std::string &source, const urdf::Joint &joint)
        {
            if (joint.type == urdf::Joint::CONTINUOUS)
                return {-M_PI, M_PI};
            if (!joint.limits)
                throw std::invalid_argument(source + ": joint '" + joint.name + "' has no <limit>");
            const double lower = joint.limits->lower, upper = joint.limits->upper;
            if (!(lower <= upper) || !std::isfinite(lower) || !std::isfinite(upper))
                throw std::invalid_argument(source + ": joint '" + joint.name + "' has invalid limits");
            return {lower, upper};
        }

        /// The held joints: fixed_joints must name movable joints, not mimics, at values within their limits.
        std::map<std::string, double> heldJoints(const RobotSpec &spec, const urdf::ModelInterface &model)
        {
            std::map<std::string, double> held;
            for (const auto &[name, value] : spec.fixedJoints)
            {
                const urdf::JointConstSharedPtr joint = model.getJoint(name);
                const std::string key = spec.source + ": [robot] fixed_joints." + name;
                if (!joint)
                    throw std::invalid_argument(key + ": no such joint in the URDF");
                if (!movable(*joint))
                    throw std::invalid_argument(key + ": the joint is fixed in the URDF");
                if (joint->mimic)
                    throw std::invalid_argument(key + ": a mimic joint follows '" + joint->mimic->joint_name + "'; set that joint");
                const auto [lower, upper] = jointLimits(spec.source, *joint);
                if (!std::isfinite(value) || value < lower || value > upper)
                    throw std::invalid_argument(key + ": value " + std::to_string(value) + " is outside the joint limits [" +
                                                std::to_string(lower) + ", " + std::to_string(upper) + "]");
                held[name] = value;
            }
            return held;
        }

        /// Every movable joint off the chain: a mimic follows its master; the rest are held (fixed_joints,
        /// else 0 clamped into the limits, e.g. a closed gripper). `chainJoint`: the chain's joints' indices.
        void tieJointsOffTheChain(const std::string &source, const urdf::ModelInterface &model,
                                  const std::map<std::string, double> &held, const std::map<std::string, int> &chainJoint,
                                  std::vector<RobotLink> &links)
        {
            for (RobotLink &link : links)
            {
                if (link.jointType == RobotLink::JointType::Fixed)
                    continue;
                const urdf::JointConstSharedPtr joint = model.getJoint(link.jointName);
                const auto heldValue = [&](const std::string &name) {
                    const auto found = held.find(name);
                    if (found != held.end())
                        return found->second;
                    const auto [lower, upper] = jointLimits(source, *model.getJoint(name));
                    return std::clamp(0.0, lower, upper);
                };
                std::string master = link.jointName;
                if (joint->mimic)
                {
                    master = joint->mimic->joint_name;
                    if (!model.getJoint(master))
                        throw std::invalid_argument(source + ": joint '" + link.jointName + "' mimics unknown joint '" + master + "'");
                    link.multiplier = joint->mimic->multiplier;
                    link.offset = joint->mimic->offset;
                }
                const auto inChain = chainJoint.find(master);
                if (inChain != chainJoint.end())
                    link.jointIndex = inChain->second;
                else
                {
                    link.offset += link.multiplier * heldValue(master);
                    link.multiplier = 1.0;
                }
            }
        }

        /// Collision geometry per shape; a mesh keeps its triangles (`surface`) only in the hand: the object
        /// enters the hand (between its jaws), while an arm link's hull only adds clearance, and checking its
        /// triangles slows every plan (the UR5's forearm, hull 1.55 x its volume, more than doubled the
        /// planning time: docs/benchmarks/robots.md).
        void prepareShapes(std::vector<RobotLink> &links, int wrist)
        {
            for (std::size_t i = 0; i < links.size(); ++i)
            {
                bool inHand = false;
                for (int j = static_cast<int>(i); j >= 0 && !inHand; j = links[j].parent)
                    inHand = links[j].jointIndex == wrist;
                for (LinkShape &shape : links[i].shapes)
                {
                    if (!inHand)
                        shape.surface = nullptr;
                    shape.geometry = linkGeometry(shape);
                }
            }
        }
    }  // namespace

    Eigen::Matrix<double, 6, 1> poseError(const Eigen::Isometry3d &current, const Eigen::Isometry3d &target)
    {
        Eigen::Matrix<double, 6, 1> error;
        error.head<3>() = target.translation() - current.translation();
        const Eigen::AngleAxisd rotation(target.linear() * current.linear().transpose());
        error.tail<3>() = rotation.angle() * rotation.axis();
        return error;
    }

    RobotModel::RobotModel(const std::string &urdfXml, const std::string &tipLink, const Eigen::Isometry3d &basePose,
                           const std::string &source)
      : RobotModel([&] {
          RobotSpec spec;
          spec.urdf = urdfXml;
          spec.source = source;
          spec.basePose = basePose;
          spec.tipLink = tipLink;
          return spec;
      }())
    {
    }

    RobotModel::RobotModel(const RobotSpec &spec)
      : source_(spec.source), tipLink_(spec.tipLink), basePose_(spec.basePose)
    {
        const std::string &source = spec.source;
        if (!basePose_.matrix().allFinite())
            throw std::invalid_argument(source + ": base_pose is not finite");
        if (!spec.tipOffset.matrix().allFinite())
            throw std::invalid_argument(source + ": tip_offset is not finite");
        const urdf::ModelInterfaceSharedPtr model = parseUrdf(spec);
        const TreeRelease release{model};  // a loop of joints away from the root: links that hold each other
        requireOneParent(source, *model);
        links_ = readLinks(spec, *model);

        const int tip = linkIndex(spec.tipLink);
        if (tip < 0)
            throw std::invalid_argument(source + ": [hand] tip_link '" + spec.tipLink + "' is not a link of the URDF");
        const int base = spec.baseLink.empty() ? 0 : linkIndex(spec.baseLink);
        if (base < 0)
            throw std::invalid_argument(source + ": [robot] base_link '" + spec.baseLink + "' is not a link of the URDF");
        const std::vector<int> tipPath = pathTo(tip);
        const auto baseOnPath = std::find(tipPath.begin(), tipPath.end(), base);
        if (base != 0 && baseOnPath == tipPath.end())
            throw std::invalid_argument(source + ": [hand] tip_link '" + spec.tipLink + "' is not downstream of base_link '" +
                                        spec.baseLink + "'");
        const std::map<std::string, double> held = heldJoints(spec, *model);

        // The chain: movable joints between the base link and the tip link, neither held nor mimic.
        std::map<std::string, int> chainJoint;
        for (auto it = base == 0 ? tipPath.begin() : std::next(baseOnPath); it != tipPath.end(); ++it)
        {
            const RobotLink &link = links_[*it];
            const urdf::JointConstSharedPtr joint = model->getJoint(link.jointName);
            // A held joint may lie between base and tip, e.g. the finger joint of a gripper pad.
            if (link.jointType == RobotLink::JointType::Fixed || joint->mimic || held.count(link.jointName))
                continue;
            const auto [lower, upper] = jointLimits(source, *joint);
            chainJoint[link.jointName] = static_cast<int>(jointNames_.size());
            jointNames_.push_back(link.jointName);
            lower_.conservativeResize(dof());
            upper_.conservativeResize(dof());
            velocity_.conservativeResize(dof());
            lower_(dof() - 1) = lower;
            upper_(dof() - 1) = upper;
            velocity_(dof() - 1) = joint->limits && std::isfinite(joint->limits->velocity) ? joint->limits->velocity : 0.0;
            revolute_.push_back(link.jointType == RobotLink::JointType::Revolute);
        }
        if (dof() == 0)
            throw std::invalid_argument(source + ": no movable joint between the base link and '" + spec.tipLink + "'");
        if (dof() > static_cast<unsigned int>(kMaxJoints))
            throw std::invalid_argument(source + ": " + std::to_string(dof()) + " movable joints between the base link and '" +
                                        spec.tipLink + "'; at most " + std::to_string(kMaxJoints) +
                                        " are supported (hold the others with [robot] fixed_joints)");
        tieJointsOffTheChain(source, *model, held, chainJoint, links_);
        tip_ = framePath(spec.tipLink, spec.tipOffset);
        prepareShapes(links_, static_cast<int>(dof()) - 1);
    }

    RobotModel RobotModel::fromFile(const std::string &path, const std::string &tipLink, const Eigen::Isometry3d &basePose)
    {
        std::ifstream file(path);
        if (!file)
            throw std::invalid_argument(path + ": cannot open URDF file");
        std::stringstream text;
        text << file.rdbuf();
        RobotSpec spec;
        spec.urdf = text.str();
        spec.source = path;
        spec.directory = path.substr(0, path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/'));
        spec.basePose = basePose;
        spec.tipLink = tipLink;
        return RobotModel(spec);
    }

    int RobotModel::linkIndex(const std::string &name) const
    {
        for (std::size_t i = 0; i < links_.size(); ++i)
            if (links_[i].name == name)
                return static_cast<int>(i);
        return -1;
    }

    std::vector<int> RobotModel::pathTo(int link) const
    {
        std::vector<int> path;
        for (int i = link; i > 0; i = links_[i].parent)
            path.push_back(i);
        std::reverse(path.begin(), path.end());
        return path;
    }

    RobotModel::FramePath RobotModel::framePath(const std::string &link, const Eigen::Isometry3d &offset) const
    {
        const int index = linkIndex(link);
        if (index < 0)
            throw std::invalid_argument(source_ + ": unknown link '" + link + "'");
        return {pathTo(index), offset};
    }

    bool RobotModel::withinLimits(const JointsRef &q, double tolerance) const
    {
        return q.size() == lower_.size() && (q.array() >= lower_.array() - tolerance).all() &&
               (q.array() <= upper_.array() + tolerance).all();
    }

    void RobotModel::moveJoint(Eigen::Isometry3d &pose, const RobotLink &link, double value)
    {
        if (link.jointType == RobotLink::JointType::Prismatic)
            pose.translation() += pose.linear() * (value * link.axis);
        if (link.jointType != RobotLink::JointType::Revolute)
            return;
        // About a coordinate axis (most URDFs) the rotation turns two columns of the pose in place:
        // the kernel's hot spot, 12 products instead of a 3x3 matrix product.
        for (int k = 0; k < 3; ++k)
            if (std::abs(link.axis(k)) == 1.0)
            {
                const double angle = link.axis(k) * value, c = std::cos(angle), s = std::sin(angle);
                const int a = (k + 1) % 3, b = (k + 2) % 3;
                const Eigen::Vector3d u = pose.linear().col(a), v = pose.linear().col(b);
                pose.linear().col(a) = c * u + s * v;
                pose.linear().col(b) = c * v - s * u;
                return;
            }
        pose.linear() = pose.linear() * Eigen::AngleAxisd(value, link.axis).toRotationMatrix();
    }

    Eigen::Isometry3d RobotModel::pathPose(const FramePath &path, const JointsRef &q) const
    {
        Eigen::Isometry3d pose = basePose_;
        for (const int i : path.links)
        {
            const RobotLink &link = links_[i];
            pose = pose * link.origin;
            if (link.jointType != RobotLink::JointType::Fixed)
                moveJoint(pose, link, jointValue(link, q));
        }
        return pose * path.offset;
    }

    Jacobian RobotModel::pathJacobian(const FramePath &path, const JointsRef &q, Eigen::Isometry3d *poseOut) const
    {
        // Column of a revolute joint: (a x (p_tip - p), a) = (-a x p, a) + (a x p_tip, 0); the second
        // term is added once p_tip is known, so one pass over the path suffices.
        Jacobian jacobian = Jacobian::Zero(6, dof());
        Eigen::Isometry3d pose = basePose_;
        for (const int i : path.links)
        {
            const RobotLink &link = links_[i];
            pose = pose * link.origin;
            if (link.jointType == RobotLink::JointType::Fixed)
                continue;
            if (link.jointIndex >= 0)
            {
                const Eigen::Vector3d axis = pose.linear() * link.axis;
                auto column = jacobian.col(link.jointIndex);
                if (link.jointType == RobotLink::JointType::Revolute)
                {
                    column.head<3>() -= link.multiplier * axis.cross(pose.translation());
                    column.tail<3>() += link.multiplier * axis;
                }
                else
                    column.head<3>() += link.multiplier * axis;
            }
            moveJoint(pose, link, jointValue(link, q));
        }
        const Eigen::Isometry3d frame = pose * path.offset;
        for (Eigen::Index j = 0; j < jacobian.cols(); ++j)
            jacobian.col(j).head<3>() += jacobian.col(j).tail<3>().cross(frame.translation());
        if (poseOut)
            *poseOut = frame;
        return jacobian;
    }

    Eigen::Isometry3d RobotModel::fk(const JointsRef &q) const
    {
        return pathPose(tip_, q);
    }

    Jacobian RobotModel::jacobian(const JointsRef &q) const
    {
        return pathJacobian(tip_, q);
    }

    Eigen::Isometry3d RobotModel::framePose(const JointsRef &q, const std::string &link,
                                            const Eigen::Isometry3d &offset) const
    {
        return pathPose(framePath(link, offset), q);
    }

    void RobotModel::linkPoses(const JointsRef &q, std::vector<Eigen::Isometry3d> &poses) const
    {
        poses.resize(links_.size());
        poses[0] = basePose_;
        for (std::size_t i = 1; i < links_.size(); ++i)
        {
            const RobotLink &link = links_[i];
            poses[i] = poses[link.parent] * link.origin;
            if (link.jointType != RobotLink::JointType::Fixed)
                moveJoint(poses[i], link, jointValue(link, q));
        }
    }

    Eigen::Isometry3d RobotModel::referenceFramePose(const JointsRef &q, const std::string &link,
                                                     const Eigen::Isometry3d &offset) const
    {
        // A local KDL chain from the root: KDL caches joint poses in mutable members (not thread-safe).
        const FramePath path = framePath(link, offset);
        KDL::Chain chain;
        std::vector<double> values;
        for (const int i : path.links)
        {
            chain.addSegment(links_[i].segment);
            if (links_[i].jointType != RobotLink::JointType::Fixed)
                values.push_back(jointValue(links_[i], q));
        }
        KDL::JntArray joints(chain.getNrOfJoints());
        for (std::size_t j = 0; j < values.size(); ++j)
            joints(static_cast<unsigned>(j)) = values[j];
        KDL::Frame frame;
        KDL::ChainFkSolverPos_recursive(chain).JntToCart(joints, frame);
        return basePose_ * toEigen(frame) * offset;
    }

    Eigen::Matrix<double, 6, Eigen::Dynamic> RobotModel::referenceJacobian(const JointsRef &q) const
    {
        KDL::Chain chain;
        std::vector<int> column;  // chain joint index of each KDL joint, -1 if held or a mimic
        std::vector<double> values;
        for (const int i : tip_.links)
        {
            chain.addSegment(links_[i].segment);
            if (links_[i].jointType != RobotLink::JointType::Fixed)
            {
                values.push_back(jointValue(links_[i], q));
                column.push_back(links_[i].jointIndex >= 0 && links_[i].multiplier == 1.0 && links_[i].offset == 0.0
                                     ? links_[i].jointIndex
                                     : -1);
            }
        }
        KDL::Frame offset;
        for (int r = 0; r < 3; ++r)
        {
            offset.p(r) = tip_.offset.translation()(r);
            for (int c = 0; c < 3; ++c)
                offset.M(r, c) = tip_.offset.linear()(r, c);
        }
        chain.addSegment(KDL::Segment(KDL::Joint(KDL::Joint::None), offset));
        KDL::JntArray joints(chain.getNrOfJoints());
        for (std::size_t j = 0; j < values.size(); ++j)
            joints(static_cast<unsigned>(j)) = values[j];
        KDL::Jacobian kdl(chain.getNrOfJoints());
        KDL::ChainJntToJacSolver(chain).JntToJac(joints, kdl);
        Eigen::Matrix<double, 6, Eigen::Dynamic> world = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, dof());
        for (std::size_t j = 0; j < column.size(); ++j)
            if (column[j] >= 0)
            {
                world.col(column[j]).head<3>() = basePose_.linear() * kdl.data.col(static_cast<long>(j)).head<3>();
                world.col(column[j]).tail<3>() = basePose_.linear() * kdl.data.col(static_cast<long>(j)).tail<3>();
            }
        return world;
    }

    Eigen::VectorXd RobotModel::randomConfiguration(std::mt19937_64 &rng) const
    {
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        Eigen::VectorXd q(dof());
        for (unsigned i = 0; i < dof(); ++i)
            q(i) = lower_(i) + unit(rng) * (upper_(i) - lower_(i));
        return q;
    }

    bool RobotModel::ik(const Eigen::Isometry3d &target, const Eigen::VectorXd &seed, std::mt19937_64 &rng,
                        Eigen::VectorXd &solution, const IkOptions &options) const
    {
        return solveIk(tip_, target, seed, rng, solution, options);
    }

    bool RobotModel::ikForLink(const std::string &link, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                               std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options,
                               const Eigen::Isometry3d &offset) const
    {
        const FramePath path = framePath(link, offset);
        std::set<int> moving;
        for (const int i : path.links)
            if (links_[i].jointIndex >= 0)
                moving.insert(links_[i].jointIndex);
        if (moving.size() != dof())
            throw std::invalid_argument(source_ + ": link '" + link + "' is not moved by every joint of the chain to '" +
                                        tipLink_ + "'");
        return solveIk(path, target, seed, rng, solution, options);
    }

    bool RobotModel::solveIk(const FramePath &path, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                             std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options) const
    {
        if (!target.matrix().allFinite())
            return false;
        const auto converged = [&](const Eigen::Matrix<double, 6, 1> &error) {
            return error.head<3>().norm() < options.positionTolerance && error.tail<3>().norm() < options.orientationTolerance;
        };
        // With a rotation tolerance the error and the Jacobian's rotation rows are taken about its axes,
        // and a rotation inside the band counts as none: its row is zeroed, so the step leaves it be.
        const bool tolerant = (options.rotationTolerance.array() > 0.0).any();
        const Eigen::Matrix3d axes = options.worldAxes ? Eigen::Matrix3d::Identity() : Eigen::Matrix3d(target.linear());
        const auto tolerate = [&](Eigen::Matrix<double, 6, 1> &error, Jacobian &jac) {
            if (!tolerant)
                return;
            Eigen::Vector3d rotation = axes.transpose() * error.tail<3>();
            jac.bottomRows<3>() = axes.transpose() * jac.bottomRows<3>();
            for (int k = 0; k < 3; ++k)
            {
                const double band = options.rotationTolerance(k);
                if (band <= 0.0)
                    continue;
                rotation(k) -= std::clamp(rotation(k), -band, band);
                if (rotation(k) == 0.0)
                    jac.row(3 + k).setZero();
            }
            error.tail<3>() = rotation;
        };
        for (int attempt = 0; attempt < options.maxAttempts; ++attempt)
        {
            if (attempt > 0 && options.stop && options.stop())
                return false;
            JointVector q;
            if (attempt == 0 && seed.size() == static_cast<long>(dof()))
                q = seed;
            else
                q = randomConfiguration(rng);
            q = q.cwiseMax(lower_).cwiseMin(upper_);
            // One kinematics pass per iteration: a candidate's pass gives its pose and, should it be
            // taken, the Jacobian of the next step; a rejected step keeps the Jacobian it had.
            Eigen::Isometry3d pose;
            Jacobian jac = pathJacobian(path, q, &pose);
            Eigen::Matrix<double, 6, 1> error = poseError(pose, target);
            tolerate(error, jac);
            double cost = error.squaredNorm();
            // Levenberg-Marquardt damping: shrink after a good step, grow after a bad one.
            double lambda = 1e-2;
            for (int iteration = 0; iteration < options.maxIterations && !converged(error); ++iteration)
            {
                if (iteration == options.abandonAfter && iteration > 0 &&
                    error.head<3>().norm() + error.tail<3>().norm() > options.abandonError)
                    break;
                const Eigen::Matrix<double, 6, 6> jjt = jac * jac.transpose() + lambda * Eigen::Matrix<double, 6, 6>::Identity();
                const JointVector step = jac.transpose() * jjt.ldlt().solve(error);
                const JointVector candidate = (q + step).cwiseMax(lower_).cwiseMin(upper_);
                Jacobian candidateJac = pathJacobian(path, candidate, &pose);
                Eigen::Matrix<double, 6, 1> candidateError = poseError(pose, target);
                tolerate(candidateError, candidateJac);
                const double candidateCost = candidateError.squaredNorm();
                if (candidateCost < cost)
                {
                    q = candidate;
                    jac = candidateJac;
                    error = candidateError;
                    cost = candidateCost;
                    lambda = std::max(lambda * 0.1, 1e-12);
                }
                else
                {
                    lambda *= 10.0;
                    if (lambda > 1e4)
                        break;  // stuck at a joint limit or a local minimum: restart
                }
            }
            if (converged(error))
            {
                // A revolute joint with more than a turn of range reaches the same pose at q and q +- 2 pi:
                // return the turn nearest the seed (else nearest zero), so that solutions share a branch.
                const bool seeded = seed.size() == q.size();
                for (Eigen::Index j = 0; j < q.size(); ++j)
                {
                    if (!revolute_[static_cast<std::size_t>(j)] || upper_(j) - lower_(j) <= 2.0 * M_PI)
                        continue;
                    const double reference = seeded ? seed(j) : 0.0;
                    const double nearest = reference + std::remainder(q(j) - reference, 2.0 * M_PI);
                    if (nearest >= lower_(j) && nearest <= upper_(j))
                        q(j) = nearest;
                }
                if (options.accept && !options.accept(q))
                    continue;
                solution = q;
                return true;
            }
        }
        return false;
    }

}  // namespace slideplan
