#include "slideplan/collision.hpp"

#include <algorithm>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision_object.h>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

namespace slideplan
{
    namespace
    {
        /// A vertical prism over a counter-clockwise convex polygon.
        std::shared_ptr<fcl::Convexd> makePrism(const std::vector<Eigen::Vector2d> &polygon, double bottom, double top)
        {
            const int n = static_cast<int>(polygon.size());
            auto vertices = std::make_shared<std::vector<Eigen::Vector3d>>();
            for (const Eigen::Vector2d &p : polygon)
                vertices->emplace_back(p.x(), p.y(), bottom);
            for (const Eigen::Vector2d &p : polygon)
                vertices->emplace_back(p.x(), p.y(), top);
            auto faces = std::make_shared<std::vector<int>>();
            faces->push_back(n);  // top, counter-clockwise seen from above
            for (int i = 0; i < n; ++i)
                faces->push_back(n + i);
            faces->push_back(n);  // bottom, reversed
            for (int i = n - 1; i >= 0; --i)
                faces->push_back(i);
            for (int i = 0; i < n; ++i)
                faces->insert(faces->end(), {4, i, (i + 1) % n, n + (i + 1) % n, n + i});
            return std::make_shared<fcl::Convexd>(vertices, n + 2, faces);
        }

        bool collide(const fcl::CollisionObjectd &a, const fcl::CollisionObjectd &b)
        {
            if (!a.getAABB().overlap(b.getAABB()))
                return false;
            fcl::CollisionRequestd request;
            fcl::CollisionResultd result;
            fcl::collide(&a, &b, request, result);
            return result.isCollision();
        }
    }  // namespace

    std::shared_ptr<fcl::CollisionGeometryd> linkGeometry(const LinkShape &shape)
    {
        switch (shape.type)
        {
            case LinkShape::Type::Box:
                return std::make_shared<fcl::Boxd>(shape.size.x(), shape.size.y(), shape.size.z());
            case LinkShape::Type::Cylinder:
                return std::make_shared<fcl::Cylinderd>(shape.size.x(), shape.size.y());
            case LinkShape::Type::Sphere:
                return std::make_shared<fcl::Sphered>(shape.size.x());
            case LinkShape::Type::Mesh:
            {
                if (shape.surface)  // the hull would fill a concavity (kConcaveHullRatio)
                {
                    auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
                    std::vector<fcl::Triangle> triangles;
                    triangles.reserve(shape.surface->triangles.size());
                    for (const Eigen::Vector3i &t : shape.surface->triangles)
                        triangles.emplace_back(t.x(), t.y(), t.z());
                    model->beginModel();
                    model->addSubModel(shape.surface->vertices, triangles);
                    model->endModel();
                    return model;
                }
                // The convex hull: GJK on its vertices is several times faster than a BVH of the
                // triangles (bench_core), and a hull only adds clearance.
                auto vertices = std::make_shared<std::vector<Eigen::Vector3d>>(shape.mesh->vertices);
                auto faces = std::make_shared<std::vector<int>>();
                for (const Eigen::Vector3i &t : shape.mesh->triangles)
                    faces->insert(faces->end(), {3, t.x(), t.y(), t.z()});
                return std::make_shared<fcl::Convexd>(vertices, static_cast<int>(shape.mesh->triangles.size()), faces);
            }
        }
        throw std::logic_error("unknown shape type");
    }

    struct CollisionWorld::Impl
    {
        struct RobotShape
        {
            int link;
            Eigen::Isometry3d origin;
            std::unique_ptr<fcl::CollisionObjectd> object;
            bool contact;
        };
        struct EnvironmentPiece
        {
            std::string name;
            std::unique_ptr<fcl::CollisionObjectd> object;
            bool touchable;  ///< table or object: contact links may penetrate it while sliding
        };
        std::vector<RobotShape> shapes;
        std::vector<EnvironmentPiece> environment;
        std::size_t firstObjectPiece{0};
        std::vector<std::pair<int, int>> selfPairs;
        std::vector<std::pair<std::string, std::string>> alwaysInContact;
        double tableTop{0.0};
        mutable std::vector<Eigen::Isometry3d> poses;
        /// Per link asked of rigidCollision: the shapes rigid with it and their poses in its frame.
        std::map<int, std::vector<std::pair<std::size_t, Eigen::Isometry3d>>> rigid;

        void pose(const RobotModel &robot, const JointsRef &q)
        {
            robot.linkPoses(q, poses);
            for (RobotShape &shape : shapes)
            {
                shape.object->setTransform(poses[shape.link] * shape.origin);
                shape.object->computeAABB();
            }
        }

        void addEnvironment(const std::string &name, std::shared_ptr<fcl::CollisionGeometryd> geometry,
                            const Eigen::Isometry3d &pose, bool touchable)
        {
            auto object = std::make_unique<fcl::CollisionObjectd>(geometry, pose);
            object->computeAABB();
            environment.push_back({name, std::move(object), touchable});
        }
    };

    CollisionWorld::CollisionWorld(std::shared_ptr<const RobotModel> robot, const SupportSurface &table,
                                   const std::vector<Obstacle> &obstacles,
                                   const std::vector<std::string> &contactLinks, double tableDepth)
      : robot_(std::move(robot)), impl_(std::make_unique<Impl>())
    {
        if (!(tableDepth > 0.0))
            throw std::invalid_argument("table depth must be positive");
        std::set<int> contact;
        for (const std::string &name : contactLinks)
        {
            const int index = robot_->linkIndex(name);
            if (index < 0)
                throw std::invalid_argument("contact link '" + name + "' is not a link of the robot");
            contact.insert(index);
        }
        const auto &links = robot_->links();
        for (std::size_t i = 0; i < links.size(); ++i)
            for (const LinkShape &shape : links[i].shapes)
            {
                // Hulls and primitives are shared by every world; a BVH is copied (not rebuilt) into
                // each: shared between threads, FCL's BVH checks made plans differ from their twins.
                std::shared_ptr<fcl::CollisionGeometryd> geometry = shape.geometry;
                if (const auto *bvh = dynamic_cast<const fcl::BVHModel<fcl::OBBRSSd> *>(geometry.get()))
                    geometry = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>(*bvh);
                impl_->shapes.push_back({static_cast<int>(i), shape.origin, std::make_unique<fcl::CollisionObjectd>(geometry),
                                         contact.count(static_cast<int>(i)) > 0});
            }

        // The table: one convex prism if Q is convex, else one per ear-clipping triangle.
        impl_->tableTop = table.height();
        const double bottom = table.height() - tableDepth;
        const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
        if (table.isConvex())
        {
            std::vector<Eigen::Vector2d> polygon;
            for (int i = 0; i < table.size(); ++i)
                polygon.emplace_back(table.vertices().row(i));
            impl_->addEnvironment("table", makePrism(polygon, bottom, table.height()), identity, true);
        }
        else
            for (const auto &triangle : table.triangles())
            {
                std::vector<Eigen::Vector2d> polygon;
                for (int v : triangle)
                    polygon.emplace_back(table.vertices().row(v));
                impl_->addEnvironment("table", makePrism(polygon, bottom, table.height()), identity, true);
            }
        for (std::size_t i = 0; i < obstacles.size(); ++i)
        {
            const Obstacle &obstacle = obstacles[i];
            obstacle.validate(i);
            const std::string name = "obstacle" + std::to_string(i);
            switch (obstacle.shape)
            {
                case Obstacle::Shape::Box:
                    impl_->addEnvironment(name, std::make_shared<fcl::Boxd>(obstacle.size.x(), obstacle.size.y(), obstacle.size.z()),
                                          obstacle.pose, false);
                    break;
                case Obstacle::Shape::Cylinder:
                    impl_->addEnvironment(name, std::make_shared<fcl::Cylinderd>(obstacle.size.x(), obstacle.size.y()),
                                          obstacle.pose, false);
                    break;
                case Obstacle::Shape::Prism:
                    impl_->addEnvironment(name, makePrism(obstacle.polygon, obstacle.bottom(), obstacle.bottom() + obstacle.height()),
                                          Eigen::Isometry3d::Identity(), false);
                    break;
            }
        }
        impl_->firstObjectPiece = impl_->environment.size();

        // Self-collision pairs: links joined by fixed joints form one body; skip pairs within a body,
        // pairs of bodies joined by one movable joint, and pairs in contact in almost every random
        // configuration (modelling overlap, e.g. a shoulder sphere and the upper arm).
        std::vector<int> body(links.size());
        for (std::size_t i = 0; i < links.size(); ++i)
            body[i] = links[i].parent >= 0 && links[i].jointType == RobotLink::JointType::Fixed
                          ? body[links[i].parent]
                          : static_cast<int>(i);
        const auto bodyParent = [&](int b) { return links[b].parent >= 0 ? body[links[b].parent] : -1; };
        std::vector<std::pair<int, int>> candidates;
        for (std::size_t a = 0; a < impl_->shapes.size(); ++a)
            for (std::size_t b = a + 1; b < impl_->shapes.size(); ++b)
            {
                const int ba = body[impl_->shapes[a].link], bb = body[impl_->shapes[b].link];
                if (ba != bb && bodyParent(ba) != bb && bodyParent(bb) != ba)
                    candidates.emplace_back(static_cast<int>(a), static_cast<int>(b));
            }
        std::mt19937_64 rng(1);
        constexpr int samples = 200;
        std::vector<int> hits(candidates.size(), 0);
        for (int s = 0; s < samples; ++s)
        {
            impl_->pose(*robot_, robot_->randomConfiguration(rng));
            for (std::size_t c = 0; c < candidates.size(); ++c)
                hits[c] += collide(*impl_->shapes[candidates[c].first].object, *impl_->shapes[candidates[c].second].object);
        }
        for (std::size_t c = 0; c < candidates.size(); ++c)
        {
            if (hits[c] < samples * 95 / 100)
            {
                impl_->selfPairs.push_back(candidates[c]);
                continue;
            }
            const std::pair<std::string, std::string> names{links[impl_->shapes[candidates[c].first].link].name,
                                                            links[impl_->shapes[candidates[c].second].link].name};
            if (std::find(impl_->alwaysInContact.begin(), impl_->alwaysInContact.end(), names) == impl_->alwaysInContact.end())
                impl_->alwaysInContact.push_back(names);
        }
    }

    CollisionWorld::~CollisionWorld() = default;

    CollisionWorld::CollisionWorld(std::shared_ptr<const RobotModel> robot, std::unique_ptr<Impl> impl)
      : robot_(std::move(robot)), impl_(std::move(impl))
    {
    }

    std::unique_ptr<CollisionWorld> CollisionWorld::clone() const
    {
        const auto copy = [](const fcl::CollisionObjectd &object) {
            // FCL hands the geometry out as const but takes it as mutable; collision queries only read it.
            auto result = std::make_unique<fcl::CollisionObjectd>(
                std::const_pointer_cast<fcl::CollisionGeometryd>(object.collisionGeometry()), object.getTransform());
            result->computeAABB();
            return result;
        };
        auto impl = std::make_unique<Impl>();
        for (const Impl::RobotShape &shape : impl_->shapes)
            impl->shapes.push_back({shape.link, shape.origin, copy(*shape.object), shape.contact});
        for (const Impl::EnvironmentPiece &piece : impl_->environment)
            impl->environment.push_back({piece.name, copy(*piece.object), piece.touchable});
        impl->firstObjectPiece = impl_->firstObjectPiece;
        impl->selfPairs = impl_->selfPairs;
        impl->alwaysInContact = impl_->alwaysInContact;
        impl->tableTop = impl_->tableTop;
        return std::unique_ptr<CollisionWorld>(new CollisionWorld(robot_, std::move(impl)));
    }

    std::size_t CollisionWorld::selfPairCount() const
    {
        return impl_->selfPairs.size();
    }

    std::vector<std::pair<std::string, std::string>> CollisionWorld::alwaysInContact() const
    {
        return impl_->alwaysInContact;
    }

    void CollisionWorld::setObject(const std::vector<Eigen::Vector2d> &outlineXY, double topZ)
    {
        clearObject();
        const std::vector<Eigen::Vector2d> hull = convexHull(outlineXY);
        if (hull.size() < 3 || !(topZ > impl_->tableTop))
            throw std::invalid_argument("object outline needs 3 non-collinear points and a top above the table");
        impl_->addEnvironment("object", makePrism(hull, impl_->tableTop, topZ), Eigen::Isometry3d::Identity(), true);
    }

    void CollisionWorld::moveObject(const PlanarMotion &motion)
    {
        if (impl_->environment.size() == impl_->firstObjectPiece)
            throw std::logic_error("moveObject without an object: call setObject first");
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.linear() = Eigen::AngleAxisd(motion.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        pose.translation() << motion.x, motion.y, 0.0;
        fcl::CollisionObjectd &object = *impl_->environment.back().object;
        object.setTransform(pose);
        object.computeAABB();
    }

    void CollisionWorld::clearObject()
    {
        impl_->environment.resize(impl_->firstObjectPiece);
    }

    bool CollisionWorld::isValid(const JointsRef &q, ContactMode mode) const
    {
        return check(q, mode, nullptr);
    }

    bool CollisionWorld::objectFree(const JointsRef &q, ContactMode mode) const
    {
        if (impl_->environment.size() == impl_->firstObjectPiece)
            throw std::logic_error("objectFree without an object: call setObject first");
        return check(q, mode, nullptr, true);
    }

    std::string CollisionWorld::rigidCollision(const std::string &link, const Eigen::Isometry3d &pose) const
    {
        const int index = robot_->linkIndex(link);
        if (index < 0)
            throw std::invalid_argument("link '" + link + "' is not a link of the robot");
        auto found = impl_->rigid.find(index);
        if (found == impl_->rigid.end())
        {
            // Links with the same deepest moving joint on their path from the root move as one body; their
            // relative poses are those at any configuration.
            const auto &links = robot_->links();
            const auto mover = [&](int l) {
                while (l >= 0 && links[l].jointIndex < 0)
                    l = links[l].parent;
                return l;
            };
            robot_->linkPoses(Eigen::VectorXd::Zero(robot_->dof()), impl_->poses);
            std::vector<std::pair<std::size_t, Eigen::Isometry3d>> shapes;
            for (std::size_t s = 0; s < impl_->shapes.size(); ++s)
                if (const int l = impl_->shapes[s].link; mover(l) == mover(index))
                    shapes.emplace_back(s, impl_->poses[index].inverse() * impl_->poses[l] * impl_->shapes[s].origin);
            found = impl_->rigid.emplace(index, std::move(shapes)).first;
        }
        for (const auto &[s, relative] : found->second)
        {
            fcl::CollisionObjectd &object = *impl_->shapes[s].object;
            object.setTransform(pose * relative);
            object.computeAABB();
            for (std::size_t piece = 0; piece < impl_->firstObjectPiece; ++piece)
                if (collide(object, *impl_->environment[piece].object))
                    return robot_->links()[impl_->shapes[s].link].name + "-" + impl_->environment[piece].name;
        }
        return {};
    }

    std::vector<std::pair<std::string, std::string>> CollisionWorld::collisions(const JointsRef &q, ContactMode mode) const
    {
        std::vector<std::pair<std::string, std::string>> report;
        check(q, mode, &report);
        return report;
    }

    std::vector<bool> CollisionWorld::hiddenLines(const JointsRef &q, const Eigen::Vector3d &eye,
                                                  const Eigen::Matrix<double, Eigen::Dynamic, 3> &points, double radius) const
    {
        if (q.size() != static_cast<long>(robot_->dof()) || !q.allFinite())
            throw std::invalid_argument("configuration has the wrong size or is not finite");
        if (!eye.allFinite() || !points.allFinite() || !(radius > 0.0))
            throw std::invalid_argument("lines of sight need a finite eye and points and a radius > 0");
        impl_->pose(*robot_, q);
        std::vector<bool> hidden(static_cast<std::size_t>(points.rows()), false);
        for (Eigen::Index i = 0; i < points.rows(); ++i)
        {
            const Eigen::Vector3d line = points.row(i).transpose() - eye;
            const double length = line.norm();
            if (!(length > 0.0))
                throw std::invalid_argument("a point of a line of sight is at the eye");
            // fcl's capsule lies along its z axis, centred on its origin.
            Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
            pose.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), line / length).toRotationMatrix();
            pose.translation() = eye + 0.5 * line;
            fcl::CollisionObjectd sight(std::make_shared<fcl::Capsuled>(radius, length), pose);
            sight.computeAABB();
            hidden[static_cast<std::size_t>(i)] = std::any_of(impl_->shapes.begin(), impl_->shapes.end(),
                                                              [&](const Impl::RobotShape &shape) { return collide(*shape.object, sight); });
        }
        return hidden;
    }

    bool CollisionWorld::check(const JointsRef &q, ContactMode mode, std::vector<std::pair<std::string, std::string>> *report,
                               bool objectOnly) const
    {
        if (q.size() != static_cast<long>(robot_->dof()) || !q.allFinite())
            throw std::invalid_argument("configuration has the wrong size or is not finite");
        impl_->pose(*robot_, q);
        const auto &links = robot_->links();
        bool free = true;
        const auto hit = [&](const std::string &a, const std::string &b) {
            free = false;
            if (report)
                report->emplace_back(a, b);
            return report == nullptr;  // stop at the first hit unless a report is wanted
        };
        const auto firstPiece = impl_->environment.begin() + static_cast<long>(objectOnly ? impl_->firstObjectPiece : 0);
        for (const auto &shape : impl_->shapes)
            for (auto piece = firstPiece; piece != impl_->environment.end(); ++piece)
            {
                if (mode == ContactMode::Sliding && shape.contact && piece->touchable)
                    continue;
                if (collide(*shape.object, *piece->object) && hit(links[shape.link].name, piece->name))
                    return false;
            }
        if (objectOnly)
            return free;
        for (const auto &[a, b] : impl_->selfPairs)
            if (collide(*impl_->shapes[a].object, *impl_->shapes[b].object) &&
                hit(links[impl_->shapes[a].link].name, links[impl_->shapes[b].link].name))
                return false;
        return free;
    }

}  // namespace slideplan
