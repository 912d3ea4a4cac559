/*
 * symdyn's Pinocchio C++ peer: ns per call of Pinocchio's algorithms on the
 * arm symdyn benchmarks, no Python involved.  The C++ counterpart of
 * harness.c (same loop: a pool of K states cycled, one volatile sink per
 * call, median of `reps` repetitions of `ncalls` calls), built once into the
 * cache by symdyn.bench.pin_peer against the headers of the `pin` and
 * `cmeel-eigen` wheels (Pinocchio is header-only here; nothing is linked).
 *
 * Run: pin_peer ARM STATES NCALLS REPS [FUNCTION ...]
 *
 * ARM (text, written by symdyn.bench.pin_peer.write_arm):
 *   symdyn-pin-arm 1
 *   n N
 *   gravity GX GY GZ                  gravity itself (downward) in the base frame
 *   then N lines, one per joint, parent = the previous joint (a serial chain):
 *   TYPE AX AY AZ  R00 R01 R02 PX R10 R11 R12 PY R20 R21 R22 PZ  M CX CY CZ  IXX IXY IXZ IYY IYZ IZZ  IA
 *     TYPE R (revolute) or P (prismatic) about / along the unit axis A, in the
 *     joint frame; [R | P] the joint frame's fixed placement in the parent
 *     joint's frame (at q = 0); M the mass, C the centre of mass and I the
 *     inertia about it, both in the joint frame (after the motion); IA the
 *     armature (rotor inertia reflected to the joint, G^2 Jm).
 *   An axis along x, y or z becomes JointModelR{X,Y,Z} / P{X,Y,Z}, any other
 *   JointModelRevoluteUnaligned / PrismaticUnaligned.
 * A tree, on a fixed or floating base (version 2):
 *   symdyn-pin-arm 2
 *   root KIND [M CX CY CZ IXX IXY IXZ IYY IYZ IZZ]
 *     KIND none (fixed base), free (JointModelFreeFlyer: q = x y z qx qy qz qw,
 *     v = linear, angular velocity in the base frame) or planar
 *     (JointModelPlanar: q = x y cos sin); a floating root carries the base
 *     body's inertia (mass, centre of mass, inertia about it, in its frame)
 *   n N
 *   gravity GX GY GZ
 *   then N lines: PARENT followed by a version-1 joint line; PARENT 0 is the
 *   root (the floating base, or the universe), PARENT i the i-th joint line
 *   (i < this line's joint); the placement is in the parent joint's frame.
 * Then, optionally (either version), the task frames:
 *   frames M
 *   then M lines: JOINT R00 R01 R02 PX R10 R11 R12 PY R20 R21 R22 PZ, a frame fixed to joint line
 *   JOINT (0: the root) at that placement in the joint's frame; the task-space algorithms
 *   (frames_drift, frames_jacobian) serve them in order.
 * Then, optionally, the contact set on the first K frames:
 *   contacts K KIND...   (KIND 3: a point, CONTACT_3D; 6: a surface, CONTACT_6D; LOCAL_WORLD_ALIGNED)
 *   which contact_fdyn (constraintDynamics) and contact_fdyn_derivatives (+
 *   computeConstraintDynamicsDerivatives) hold.
 * STATES: K (a power of two) states, each q (nq), qd, qdd, tau (nv each)
 *   doubles: nq = nv = N on a fixed base (the file harness.c reads, so both
 *   time the same states).  symdyn's q: a planar root's is x y yaw, turned
 *   into Pinocchio's x y cos sin here, before any timing.
 *
 * With no FUNCTION, every joint-space algorithm; the task-space ones (frames_drift,
 * frames_jacobian, com_centroidal) run when named.
 * Prints "pinocchio VERSION", then "time NAME NS" per algorithm, then
 * "check NAME v..." with its outputs at state 3 (matrices row-major and made
 * symmetric where Pinocchio fills the upper triangle only; dtau/dq and
 * dqdd/dq for the derivatives), which the caller compares with symdyn's
 * reference before it believes any time.
 */
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/cholesky.hpp>
#include <pinocchio/algorithm/rnea-derivatives.hpp>
#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/centroidal.hpp>
#include <pinocchio/algorithm/constrained-dynamics.hpp>
#include <pinocchio/algorithm/constrained-dynamics-derivatives.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace pinocchio;
typedef std::chrono::steady_clock clk;

static std::string arm_path;

/* A line of the arm file that is not what it should be: the file and line, as a compiler says it. */
[[noreturn]] static void bad(int line, const std::string &what)
{
    throw std::runtime_error(arm_path + ":" + std::to_string(line) + ": " + what);
}

/* Pinocchio's joint model for a unit axis: the axis-aligned kinds where they apply (faster). */
static JointIndex add_joint(Model &model, JointIndex parent, char type, const Eigen::Vector3d &axis,
                            const SE3 &placement, const std::string &name)
{
    for (int k = 0; k < 3; ++k) {
        if (std::abs(axis[k] - 1.0) < 1e-15 && std::abs(axis[(k + 1) % 3]) < 1e-15 &&
            std::abs(axis[(k + 2) % 3]) < 1e-15) {
            if (type == 'R')
                return k == 0 ? model.addJoint(parent, JointModelRX(), placement, name)
                     : k == 1 ? model.addJoint(parent, JointModelRY(), placement, name)
                              : model.addJoint(parent, JointModelRZ(), placement, name);
            return k == 0 ? model.addJoint(parent, JointModelPX(), placement, name)
                 : k == 1 ? model.addJoint(parent, JointModelPY(), placement, name)
                          : model.addJoint(parent, JointModelPZ(), placement, name);
        }
    }
    if (type == 'R')
        return model.addJoint(parent, JointModelRevoluteUnaligned(axis), placement, name);
    return model.addJoint(parent, JointModelPrismaticUnaligned(axis), placement, name);
}

static bool is_task_space(const std::string &name)
{
    return name.rfind("frames_", 0) == 0 || name.rfind("contact_", 0) == 0 || name == "com_centroidal";
}

static std::vector<FrameIndex> task_frames;  /* the frames of the arm file's "frames" section */
static std::vector<int> contact_kinds;         /* its "contacts" section: 3 or 6 per frame */

static Model read_arm(const char *path)
{
    arm_path = path;
    std::ifstream in(path);
    if (!in)
        throw std::runtime_error(arm_path + ": cannot open");
    std::string line, word, root = "none";
    int version = 0, n = 0, lineno = 1;
    double gx, gy, gz, b[10] = {0};
    if (!std::getline(in, line) || !(std::istringstream(line) >> word >> version) || word != "symdyn-pin-arm" ||
        (version != 1 && version != 2))
        bad(1, "not a symdyn arm file (first line must be 'symdyn-pin-arm 1' or 'symdyn-pin-arm 2')");
    Model model;
    JointIndex base = 0;
    if (version == 2) {
        ++lineno;
        std::istringstream s;
        if (std::getline(in, line))
            s.str(line);
        if (!(s >> word >> root) || word != "root" || (root != "none" && root != "free" && root != "planar"))
            bad(lineno, "expected 'root none', 'root free M C I' or 'root planar M C I'");
        if (root != "none") {
            for (double &x : b)
                s >> x;
            if (!s)
                bad(lineno, "the floating root needs the base body's 10 numbers (M CX CY CZ IXX IXY IXZ IYY IYZ IZZ)");
            base = root == "free" ? model.addJoint(0, JointModelFreeFlyer(), SE3::Identity(), "root_joint")
                                  : model.addJoint(0, JointModelPlanar(), SE3::Identity(), "root_joint");
            Eigen::Matrix3d I;
            I << b[4], b[5], b[6], b[5], b[7], b[8], b[6], b[8], b[9];
            model.appendBodyToJoint(base, Inertia(b[0], Eigen::Vector3d(b[1], b[2], b[3]), I), SE3::Identity());
        }
    }
    ++lineno;
    if (!std::getline(in, line) || !(std::istringstream(line) >> word >> n) || word != "n" || n < (root == "none"))
        bad(lineno, "expected 'n N' with N >= 1 joints (N >= 0 on a floating root: a lone body)");
    ++lineno;
    if (!std::getline(in, line) || !(std::istringstream(line) >> word >> gx >> gy >> gz) || word != "gravity")
        bad(lineno, "expected 'gravity GX GY GZ'");
    std::vector<JointIndex> index(1, base);  /* index[i]: the Pinocchio joint of line i (0: the root) */
    std::vector<double> armature;
    for (int i = 0; i < n; ++i) {
        ++lineno;
        if (!std::getline(in, line))
            bad(lineno, "missing joint " + std::to_string(i + 1) + " of " + std::to_string(n));
        std::istringstream s(line);
        std::string type;
        int up = i;  /* version 1: a serial chain, each joint on the previous one */
        double v[26];
        if (version == 2 && (!(s >> up) || up < 0 || up > i))
            bad(lineno, "joint " + std::to_string(i + 1) + ": expected its parent 0.." + std::to_string(i) + " first");
        s >> type;
        for (double &x : v)
            s >> x;
        if (!s || (type != "R" && type != "P"))
            bad(lineno, "joint " + std::to_string(i + 1) + ": expected R or P and 26 numbers");
        Eigen::Vector3d axis(v[0], v[1], v[2]);
        if (std::abs(axis.norm() - 1.0) > 1e-12)
            bad(lineno, "joint " + std::to_string(i + 1) + ": the axis is not a unit vector");
        Eigen::Matrix3d R;
        Eigen::Vector3d p;
        for (int r = 0; r < 3; ++r) {
            R.row(r) << v[3 + 4 * r], v[4 + 4 * r], v[5 + 4 * r];
            p[r] = v[6 + 4 * r];
        }
        if (!(R.transpose() * R).isIdentity(1e-12) || R.determinant() < 0)
            bad(lineno, "joint " + std::to_string(i + 1) + ": the placement's rotation is not a rotation");
        Eigen::Matrix3d I;
        I << v[19], v[20], v[21], v[20], v[22], v[23], v[21], v[23], v[24];
        std::string name = "j" + std::to_string(i + 1);
        JointIndex j = add_joint(model, index[up], type[0], axis, SE3(R, p), name);
        model.appendBodyToJoint(j, Inertia(v[15], Eigen::Vector3d(v[16], v[17], v[18]), I), SE3::Identity());
        armature.push_back(v[25]);
        index.push_back(j);
    }
    model.armature = Eigen::VectorXd::Zero(model.nv);
    for (int i = 0; i < n; ++i)
        model.armature[model.idx_vs[index[i + 1]]] = armature[i];
    model.gravity = Motion(Eigen::Vector3d(gx, gy, gz), Eigen::Vector3d::Zero());
    int m = 0;
    ++lineno;
    if (std::getline(in, line) && !line.empty()) {
        if (!(std::istringstream(line) >> word >> m) || word != "frames" || m < 1)
            bad(lineno, "expected 'frames M' with M >= 1, or the end of the file");
        for (int f = 0; f < m; ++f) {
            ++lineno;
            std::istringstream s;
            if (std::getline(in, line))
                s.str(line);
            int on = -1;
            double v[12];
            s >> on;
            for (double &x : v)
                s >> x;
            if (!s || on < 0 || on > n)
                bad(lineno, "frame " + std::to_string(f + 1) + ": expected its joint line 0.." + std::to_string(n) +
                                " and 12 numbers");
            Eigen::Matrix3d R;
            Eigen::Vector3d p;
            for (int r = 0; r < 3; ++r) {
                R.row(r) << v[4 * r], v[4 * r + 1], v[4 * r + 2];
                p[r] = v[4 * r + 3];
            }
            const JointIndex j = index[on];
            task_frames.push_back(model.addFrame(
                Frame("task" + std::to_string(f), j, 0, SE3(R, p), FrameType::OP_FRAME)));
        }
        ++lineno;
        if (std::getline(in, line) && !line.empty()) {
            std::istringstream s(line);
            int k = 0, kind = 0;
            if (!(s >> word >> k) || word != "contacts" || k < 1 || k > m)
                bad(lineno, "expected 'contacts K KIND...' with 1 <= K <= " + std::to_string(m));
            for (int c = 0; c < k; ++c) {
                if (!(s >> kind) || (kind != 3 && kind != 6))
                    bad(lineno, "contact " + std::to_string(c + 1) + ": its kind is 3 (point) or 6 (surface)");
                contact_kinds.push_back(kind);
            }
        }
    }
    return model;
}

static std::vector<double> read_states(const char *path, int nq, int nv)
{
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in)
        throw std::runtime_error(std::string(path) + ": cannot open");
    const std::streamoff bytes = in.tellg();
    const std::size_t per = (std::size_t)nq + 3 * (std::size_t)nv;
    const std::size_t k = bytes > 0 ? (std::size_t)bytes / (sizeof(double) * per) : 0;
    if (k < 4 || (k & (k - 1)) || (std::size_t)bytes != k * per * sizeof(double))
        throw std::runtime_error(std::string(path) + ": expected a power of two (>= 4) of states of " +
                                 std::to_string(per) + " doubles each");
    std::vector<double> states(k * per);
    in.seekg(0);
    in.read(reinterpret_cast<char *>(states.data()), (std::streamsize)(states.size() * sizeof(double)));
    return states;
}

template <typename F>
static double time_ns(F f, long ncalls, int reps)
{
    std::vector<double> v;
    for (int r = 0; r < reps; ++r) {
        volatile char pad[1 + 64 * (r * 37 % 64)];  // each repetition at another stack placement (harness.c)
        pad[0] = 0;
        auto t0 = clk::now();
        for (long i = 0; i < ncalls; ++i)
            f(i);
        auto t1 = clk::now();
        v.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / (double)ncalls);
    }
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

static void check(const char *name, const Eigen::MatrixXd &m)
{
    std::printf("check %s", name);
    for (Eigen::Index r = 0; r < m.rows(); ++r)
        for (Eigen::Index c = 0; c < m.cols(); ++c)
            std::printf(" %.17g", m(r, c));
    std::printf("\n");
}

static Eigen::MatrixXd symmetric_from_upper(const Eigen::MatrixXd &m)
{
    Eigen::MatrixXd s = m;
    s.triangularView<Eigen::StrictlyLower>() = m.transpose();
    return s;
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        std::fprintf(stderr, "usage: %s ARM STATES NCALLS REPS [FUNCTION ...]\n", argv[0]);
        return 2;
    }
    try {
        const Model model = read_arm(argv[1]);
        const bool planar = model.njoints > 1 && model.joints[1].shortname() == "JointModelPlanar";
        const int n = model.nv, nq = model.nq - (planar ? 1 : 0);  /* symdyn's nq */
        const std::vector<double> raw = read_states(argv[2], nq, n);
        const long ncalls = std::atol(argv[3]);
        const int reps = std::atoi(argv[4]);
        if (ncalls < 1 || reps < 1)
            throw std::runtime_error("NCALLS and REPS must be positive");
        const std::size_t W = (std::size_t)nq + 3 * (std::size_t)n, K = raw.size() / W;
        std::vector<Eigen::VectorXd> Q(K), V(K), A(K), T(K);
        for (std::size_t k = 0; k < K; ++k) {
            const double *s = raw.data() + W * k;
            Q[k] = Eigen::Map<const Eigen::VectorXd>(s, nq);
            if (planar) {  /* x y yaw, joints -> x y cos sin, joints */
                Q[k].resize(model.nq);
                Q[k] << s[0], s[1], std::cos(s[2]), std::sin(s[2]), Eigen::Map<const Eigen::VectorXd>(s + 3, nq - 3);
            }
            V[k] = Eigen::Map<const Eigen::VectorXd>(s + nq, n);
            A[k] = Eigen::Map<const Eigen::VectorXd>(s + nq + n, n);
            T[k] = Eigen::Map<const Eigen::VectorXd>(s + nq + 2 * n, n);
        }
        const std::size_t mask = K - 1;
        Data data(model);
        Eigen::VectorXd tmp(n);
        Eigen::MatrixXd dtau_dq = Eigen::MatrixXd::Zero(n, n), dtau_dv = dtau_dq, dtau_da = dtau_dq;
        Eigen::MatrixXd dddq_dq = dtau_dq, dddq_dv = dtau_dq, dddq_dtau = dtau_dq;
        volatile double sink = 0;
        const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
        std::vector<Data::Matrix6x> frameJ(task_frames.size(), Data::Matrix6x::Zero(6, n));
        std::vector<Eigen::Matrix<double, 6, 1>> drift(task_frames.size());
        /* the contact set: rigid constraints at the first frames, solved exactly (mu = 0, one iteration) */
        std::vector<RigidConstraintModel, Eigen::aligned_allocator<RigidConstraintModel>> contacts;
        std::vector<RigidConstraintData, Eigen::aligned_allocator<RigidConstraintData>> contact_datas;
        for (std::size_t c = 0; c < contact_kinds.size(); ++c) {
            const Frame &frame = model.frames[task_frames[c]];
            contacts.push_back(RigidConstraintModel(contact_kinds[c] == 3 ? CONTACT_3D : CONTACT_6D, model,
                                                    frame.parentJoint, frame.placement, LOCAL_WORLD_ALIGNED));
            contact_datas.push_back(RigidConstraintData(contacts.back()));
        }
        if (!contacts.empty())
            initConstraintDynamics(model, data, contacts, contact_datas);
        ProximalSettings prox(1e-12, 0.0, 1);
        /* per frame: its pose (16, row-major), Jacobian (6 x nv) and, with_drift, its drift (6) */
        auto task_output = [&](bool with_drift) {
            const Eigen::Index per = 16 + 6 * n + (with_drift ? 6 : 0);
            Eigen::MatrixXd out(1, per * (Eigen::Index)task_frames.size());
            for (std::size_t f = 0; f < task_frames.size(); ++f) {
                Eigen::Index at = per * (Eigen::Index)f;
                const Eigen::Matrix4d T = data.oMf[task_frames[f]].toHomogeneousMatrix();
                for (int r = 0; r < 4; ++r)
                    for (int c = 0; c < 4; ++c)
                        out(0, at++) = T(r, c);
                for (int r = 0; r < 6; ++r)
                    for (int c = 0; c < n; ++c)
                        out(0, at++) = frameJ[f](r, c);
                for (int r = 0; with_drift && r < 6; ++r)
                    out(0, at++) = drift[f][r];
            }
            return out;
        };
        auto fdyn = [&](std::size_t k) {  /* forward dynamics by CRBA + Cholesky: M^-1 (tau - nle) */
            crba(model, data, Q[k]);
            nonLinearEffects(model, data, Q[k], V[k]);
            cholesky::decompose(model, data);
            tmp = T[k] - data.nle;
            cholesky::solve(model, data, tmp);
        };
        struct Algorithm {
            const char *name;
            std::function<void(std::size_t)> call;
            std::function<Eigen::MatrixXd()> output;
        };
        const std::vector<Algorithm> algorithms = {
            {"rnea", [&](std::size_t k) { rnea(model, data, Q[k], V[k], A[k]); sink = data.tau[0]; },
             [&] { return Eigen::MatrixXd(data.tau); }},
            {"crba", [&](std::size_t k) { crba(model, data, Q[k]); sink = data.M(0, 0); },
             [&] { return symmetric_from_upper(data.M); }},
            {"crba_world", [&](std::size_t k) { crba(model, data, Q[k], Convention::WORLD); sink = data.M(0, 0); },
             [&] { return symmetric_from_upper(data.M); }},
            {"aba", [&](std::size_t k) { aba(model, data, Q[k], V[k], T[k]); sink = data.ddq[0]; },
             [&] { return Eigen::MatrixXd(data.ddq); }},
            {"computeGeneralizedGravity", [&](std::size_t k) { computeGeneralizedGravity(model, data, Q[k]); sink = data.g[0]; },
             [&] { return Eigen::MatrixXd(data.g); }},
            {"nonLinearEffects", [&](std::size_t k) { nonLinearEffects(model, data, Q[k], V[k]); sink = data.nle[0]; },
             [&] { return Eigen::MatrixXd(data.nle); }},
            {"computeCoriolisMatrix", [&](std::size_t k) { computeCoriolisMatrix(model, data, Q[k], V[k]); sink = data.C(0, 0); },
             [&] { return Eigen::MatrixXd(data.C); }},
            {"crba_cholesky", [&](std::size_t k) { fdyn(k); sink = tmp[0]; },
             [&] { return Eigen::MatrixXd(tmp); }},
            {"computeRNEADerivatives", [&](std::size_t k) {
                 computeRNEADerivatives(model, data, Q[k], V[k], A[k], dtau_dq, dtau_dv, dtau_da); sink = dtau_dq(0, 0); },
             [&] { return dtau_dq; }},
            {"computeABADerivatives", [&](std::size_t k) {
                 computeABADerivatives(model, data, Q[k], V[k], T[k], dddq_dq, dddq_dv, dddq_dtau); sink = dddq_dq(0, 0); },
             [&] { return dddq_dq; }},
            {"computeMinverse", [&](std::size_t k) { computeMinverse(model, data, Q[k]); sink = data.Minv(0, 0); },
             [&] { return symmetric_from_upper(data.Minv); }},
            /* the task space: what a legged controller asks per step (poses, world-aligned Jacobians
               and the classical acceleration at a = 0 of its feet) */
            {"frames_drift", [&](std::size_t k) {
                 forwardKinematics(model, data, Q[k], V[k], zero);
                 computeJointJacobians(model, data);
                 updateFramePlacements(model, data);
                 for (std::size_t f = 0; f < task_frames.size(); ++f) {
                     getFrameJacobian(model, data, task_frames[f], LOCAL_WORLD_ALIGNED, frameJ[f]);
                     drift[f] = getFrameClassicalAcceleration(model, data, task_frames[f], LOCAL_WORLD_ALIGNED).toVector();
                 }
                 sink = frameJ[0](0, 0); },
             [&] { return task_output(true); }},
            {"frames_jacobian", [&](std::size_t k) {
                 computeJointJacobians(model, data, Q[k]);
                 updateFramePlacements(model, data);
                 for (std::size_t f = 0; f < task_frames.size(); ++f)
                     getFrameJacobian(model, data, task_frames[f], LOCAL, frameJ[f]);
                 sink = frameJ[0](0, 0); },
             [&] { return task_output(false); }},
            {"com_centroidal", [&](std::size_t k) {
                 jacobianCenterOfMass(model, data, Q[k]);
                 computeCentroidalMap(model, data, Q[k]);
                 sink = data.Ag(0, 0); },
             [&] { Eigen::MatrixXd out(9, n); out << data.Jcom, data.Ag; return out; }},
            /* contacts: the accelerations and forces (a; lambda), then their derivatives
               [da_dq da_dv da_dtau; dlambda_dq dlambda_dv dlambda_dtau] */
            {"contact_fdyn", [&](std::size_t k) {
                 constraintDynamics(model, data, Q[k], V[k], T[k], contacts, contact_datas, prox);
                 sink = data.ddq[0]; },
             [&] { Eigen::MatrixXd out(n + data.lambda_c.size(), 1); out << data.ddq, data.lambda_c; return out; }},
            {"contact_fdyn_derivatives", [&](std::size_t k) {
                 constraintDynamics(model, data, Q[k], V[k], T[k], contacts, contact_datas, prox);
                 computeConstraintDynamicsDerivatives(model, data, contacts, contact_datas);
                 sink = data.ddq_dq(0, 0); },
             [&] {
                 const Eigen::Index nc = data.lambda_c.size();
                 Eigen::MatrixXd out(n + nc, 3 * n);
                 out << data.ddq_dq, data.ddq_dv, data.ddq_dtau, data.dlambda_dq, data.dlambda_dv, data.dlambda_dtau;
                 return out; }},
        };
        std::vector<std::string> wanted(argv + 5, argv + argc);
        for (const std::string &w : wanted)
            if (task_frames.empty() && w.rfind("frames_", 0) == 0)
                throw std::runtime_error("algorithm '" + w + "' needs the arm file's frames section");
            else if (contact_kinds.empty() && w.rfind("contact_", 0) == 0)
                throw std::runtime_error("algorithm '" + w + "' needs the arm file's contacts section");
        for (const std::string &w : wanted)
            if (std::none_of(algorithms.begin(), algorithms.end(), [&](const Algorithm &a) { return w == a.name; }))
                throw std::runtime_error("unknown algorithm '" + w + "'");
        std::printf("pinocchio %s\n", PINOCCHIO_VERSION);
        std::vector<const Algorithm *> run;
        for (const Algorithm &a : algorithms)
            if (std::find(wanted.begin(), wanted.end(), a.name) != wanted.end() ||
                (wanted.empty() && !is_task_space(a.name)))  /* the task space only when named */
                run.push_back(&a);
        for (const Algorithm *a : run) {
            const double t = time_ns([&](long i) { a->call((std::size_t)i & mask); }, ncalls, reps);
            std::printf("time %s %.2f\n", a->name, t);
        }
        for (const Algorithm *a : run) {
            a->call(3);
            check(a->name, a->output());
        }
        (void)sink;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "pin_peer: %s\n", e.what());
        return 1;
    }
    return 0;
}
