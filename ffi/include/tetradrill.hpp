// tetradrill for C++: a header-only RAII wrapper over the C interface (tetradrill.h,
// docs/FFI.md). C++20; errors are exceptions (tetradrill::error, with the status and, for a
// mesh file, its line or byte); arrays are std::span.
//
//   tetradrill::mesh_file file("tooth.msh");            // hosted builds: any mesh file
//   auto p = tetradrill::params::defaults(file.node_count(), file.tet_count());
//   tetradrill::world w(p, file);                        // owns its memory, freed on destruction
//   tetradrill::servo s = w.servo();                     // for the servo's thread or interrupt
//   td_vec3 f = w.tick({0.f, 0.f, 0.02f}, 1);            // or: w.simulate(..) and s.force(..)
//   tetradrill::surface shown(w, 1 << 16);               // the drilled surface, for drawing
//   shown.update(4096);                                  // then upload shown.ranges()
//
// The world's memory does not move while the world lives (moving a `world` moves the
// ownership, not the memory), so a `servo` taken from it stays valid until the world is
// destroyed. The simulation's calls (`simulate`, `tick`, `set_region`, `counters`, ...) belong to
// one thread, the servo's (`servo::force`, `servo::counters`) to one other; the two may overlap.
#ifndef TETRADRILL_HPP
#define TETRADRILL_HPP

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tetradrill.h"

namespace tetradrill {

// A call of the C interface that did not return TD_OK.
class error : public std::runtime_error {
  public:
    error(td_status status, const std::string &what)
        : std::runtime_error(what + ": " + td_status_name(static_cast<int32_t>(status))),
          status_(status) {}

    // The C interface's status.
    td_status status() const noexcept { return status_; }

  private:
    td_status status_;
};

// A mesh file that could not be read: the file's line (from 1; 0 when none) or byte
// (UINT64_MAX when none), and the reader's line naming the file and the reason.
class file_error : public error {
  public:
    explicit file_error(const td_file_error &e)
        : error(TD_ERR_FILE, std::string(e.message)), line_(e.line), byte_(e.byte) {}

    std::uint64_t line() const noexcept { return line_; }
    std::uint64_t byte() const noexcept { return byte_; }

  private:
    std::uint64_t line_, byte_;
};

// A refused mesh or blob, naming the tet, node or byte at fault (`bad_item`).
class item_error : public error {
  public:
    item_error(td_status status, const std::string &what, std::uint32_t item)
        : error(status, what + " (item " + std::to_string(item) + ")"), item_(item) {}

    std::uint32_t item() const noexcept { return item_; }

  private:
    std::uint32_t item_;
};

namespace detail {
// Throws `error` unless `st` is TD_OK.
inline void check(td_status st, const char *what) {
    if (st != TD_OK)
        throw error(st, what);
}

// Memory at an alignment, freed with the matching delete.
struct aligned_free {
    std::size_t align;
    void operator()(std::byte *p) const noexcept {
        ::operator delete[](p, std::align_val_t(align));
    }
};
using aligned_bytes = std::unique_ptr<std::byte[], aligned_free>;

inline aligned_bytes allocate(std::size_t size, std::size_t align) {
    auto *p = static_cast<std::byte *>(::operator new[](size, std::align_val_t(align)));
    return aligned_bytes(p, aligned_free{align});
}
} // namespace detail

// The world's parameters: the C interface's defaults for a mesh's counts, then change fields.
struct params {
    static td_params defaults(std::uint32_t nodes, std::uint32_t tets) {
        td_params p{};
        detail::check(td_params_default(nodes, tets, &p), "td_params_default");
        return p;
    }
};

#if !defined(TETRADRILL_BARE_METAL)
// A mesh file read and built (every format `tetradrill` reads), with its region labels.
class mesh_file {
  public:
    explicit mesh_file(const std::string &path, double scale = 1.0) {
        td_file_error e{};
        td_mesh_file *f = nullptr;
        td_status st = td_mesh_file_read(path.c_str(), scale, &f, &e);
        if (st == TD_ERR_FILE)
            throw file_error(e);
        detail::check(st, "td_mesh_file_read");
        file_.reset(f);
        detail::check(td_mesh_file_arrays(f, &arrays_), "td_mesh_file_arrays");
    }

    std::uint32_t node_count() const noexcept { return arrays_.node_count; }
    std::uint32_t tet_count() const noexcept { return arrays_.tet_count; }
    // x, y, z per node.
    std::span<const float> positions() const noexcept {
        return {arrays_.positions, 3 * std::size_t(arrays_.node_count)};
    }
    // Four node indices per tet.
    std::span<const std::uint32_t> tets() const noexcept {
        return {arrays_.tets, 4 * std::size_t(arrays_.tet_count)};
    }
    // A region label per tet; empty when the file has none.
    std::span<const std::int32_t> labels() const noexcept {
        if (!arrays_.labels)
            return {};
        return {arrays_.labels, std::size_t(arrays_.tet_count)};
    }

  private:
    struct free_file {
        void operator()(td_mesh_file *f) const noexcept { td_mesh_file_free(f); }
    };
    std::unique_ptr<td_mesh_file, free_file> file_;
    td_mesh_arrays arrays_{};
};
#endif

// The world's servo: its force call and counters, for the servo's thread or interrupt. Does
// not own anything; valid while its world lives.
class servo {
  public:
    explicit servo(td_servo *s) noexcept : s_(s) {}

    // The force at `position` from the newest contact the simulation published.
    td_vec3 force(td_vec3 position) {
        td_vec3 f{};
        detail::check(td_servo_force(s_, position, &f), "td_servo_force");
        return f;
    }

    // The burr's spin for the next ticks: the direction of its angular velocity (zero: none);
    // with a region's friction, the sideways pull along spin x n.
    void set_spin(td_vec3 omega) { detail::check(td_servo_set_spin(s_, omega), "td_servo_set_spin"); }

    // What the burr's spring holds at `position` on the contact the last `force` used (newton
    // mesh units; zero out of contact), for a `passivity` observer.
    td_storage storage(td_vec3 position) const {
        td_storage s{};
        detail::check(td_servo_storage(s_, position, nullptr, &s), "td_servo_storage");
        return s;
    }

    // The force digest, ticks, contact ticks, stale reads and the step rendered from.
    td_servo_counts counters() const {
        td_servo_counts c{};
        detail::check(td_servo_counters(s_, &c), "td_servo_counters");
        return c;
    }

    td_servo *get() const noexcept { return s_; }

  private:
    td_servo *s_;
};

// A servo loop's passivity observer and controller (td_passivity_*), SI units, in memory it
// owns; move-only. Each tick: the force to send the device for the law's force at a position,
// given what the law's spring holds there (or nothing).
class passivity {
  public:
    static td_passivity_params defaults() {
        td_passivity_params p{};
        detail::check(td_passivity_params_default(&p), "td_passivity_params_default");
        return p;
    }

    explicit passivity(const td_passivity_params &p = defaults()) {
        std::size_t size = 0, align = 0;
        detail::check(td_passivity_size(&size, &align), "td_passivity_size");
        mem_ = detail::allocate(size, align);
        detail::check(td_passivity_init(mem_.get(), size, &p, &o_), "td_passivity_init");
    }

    passivity(passivity &&o) noexcept : mem_(std::move(o.mem_)), o_(std::exchange(o.o_, nullptr)) {}
    passivity &operator=(passivity &&o) noexcept {
        mem_ = std::move(o.mem_);
        o_ = std::exchange(o.o_, nullptr);
        return *this;
    }
    passivity(const passivity &) = delete;
    passivity &operator=(const passivity &) = delete;

    // One tick: `removing` for an environment that gives way by design (the drill on).
    td_vec3 step(td_vec3 position, td_vec3 force, std::optional<td_storage> storage,
                 bool removing = false) {
        td_vec3 out{};
        detail::check(td_passivity_step(o_, position, force, storage ? &*storage : nullptr,
                                        removing ? 1u : 0u, &out),
                      "td_passivity_step");
        return out;
    }

    void restart() { detail::check(td_passivity_reset(o_, 1, 0, 0), "td_passivity_reset"); }
    void recover() { detail::check(td_passivity_reset(o_, 0, 1, 0), "td_passivity_reset"); }
    void trip() { detail::check(td_passivity_reset(o_, 0, 0, 1), "td_passivity_reset"); }

    td_passivity_counts counters() const {
        td_passivity_counts c{};
        detail::check(td_passivity_counters(o_, &c), "td_passivity_counters");
        return c;
    }

    // What a penalty spring of `stiffness` clamped at `max_force` holds at `depth`.
    static td_storage penalty(float depth, float stiffness, float max_force) {
        td_storage s{};
        detail::check(td_penalty_storage(depth, stiffness, max_force, &s), "td_penalty_storage");
        return s;
    }

  private:
    detail::aligned_bytes mem_{nullptr, detail::aligned_free{64}};
    td_passivity *o_ = nullptr;
};

// A drilling world in memory it owns, freed on destruction; move-only.
class world {
  public:
    // The world over a mesh given as arrays (x, y, z per node; four node indices per tet; a
    // label per tet, or empty for none).
    world(const td_params &p, std::span<const float> positions, std::span<const std::uint32_t> tets,
          std::span<const std::int32_t> labels = {}) {
        if (positions.size() != 3 * std::size_t(p.node_count) ||
            tets.size() != 4 * std::size_t(p.tet_count) ||
            (!labels.empty() && labels.size() != std::size_t(p.tet_count)))
            throw error(TD_ERR_PARAMS, "world: array lengths differ from the parameters' counts");
        std::size_t size = 0, align = 0;
        detail::check(td_world_size(&p, &size, &align), "td_world_size");
        mem_ = detail::allocate(size, align);
        std::uint32_t bad = 0;
        td_status st = td_world_init(mem_.get(), size, &p, positions.data(), tets.data(),
                                     labels.empty() ? nullptr : labels.data(), &w_, &bad);
        if (st == TD_ERR_MESH || st == TD_ERR_LABEL)
            throw item_error(st, "td_world_init", bad);
        detail::check(st, "td_world_init");
    }

#if !defined(TETRADRILL_BARE_METAL)
    // The world over a mesh file's arrays (they may go once the world is made).
    world(const td_params &p, const mesh_file &f)
        : world(p, f.positions(), f.tets(), f.labels()) {}
#endif

    // The world over a mesh blob read in place: `blob` must outlive the world.
    static world from_blob(const td_params &p, std::span<const std::uint8_t> blob) {
        world w;
        std::size_t size = 0, align = 0;
        detail::check(td_world_size_blob(&p, &size, &align), "td_world_size_blob");
        w.mem_ = detail::allocate(size, align);
        std::uint32_t bad = 0;
        td_status st =
            td_world_init_blob(w.mem_.get(), size, &p, blob.data(), blob.size(), &w.w_, &bad);
        if (st == TD_ERR_BLOB || st == TD_ERR_LABEL)
            throw item_error(st, "td_world_init_blob", bad);
        detail::check(st, "td_world_init_blob");
        return w;
    }

    world(world &&o) noexcept : mem_(std::move(o.mem_)), w_(std::exchange(o.w_, nullptr)) {}
    world &operator=(world &&o) noexcept {
        mem_ = std::move(o.mem_);
        w_ = std::exchange(o.w_, nullptr);
        return *this;
    }
    world(const world &) = delete;
    world &operator=(const world &) = delete;

    // A region's material (before the first step): `tetradrill`'s [regions.LABEL] values.
    void set_region(std::int32_t label, float hardness, float threshold, float stiffness = 0.f) {
        detail::check(td_world_set_region(w_, label, hardness, threshold, stiffness),
                      "td_world_set_region");
    }

    // A region's feel (before the first step): `tetradrill`'s [regions.LABEL] vibration,
    // cutting_energy and friction (0: none); the material stays.
    void set_region_feel(std::int32_t label, float vibration, float cutting_energy,
                         float friction) {
        detail::check(td_world_set_region_feel(w_, label, vibration, cutting_energy, friction),
                      "td_world_set_region_feel");
    }

    // One simulation step at `position` (bit 0 of `buttons`: the drill on), published to
    // the servo.
    td_sim_report simulate(td_vec3 position, std::uint32_t buttons) {
        td_sim_report r{};
        detail::check(td_world_simulate(w_, position, buttons, &r), "td_world_simulate");
        return r;
    }

    // The step and the servo force in one task, as `tetradrill replay` runs a tick.
    td_vec3 tick(td_vec3 position, std::uint32_t buttons) {
        td_vec3 f{};
        detail::check(td_world_tick(w_, position, buttons, &f), "td_world_tick");
        return f;
    }

    // A deformable world's nodes moved to `xyz` (x, y, z of each node; `td_params.deformable`
    // 1): boxes, hash, normals and contact caches follow. Between steps.
    td_deform_report set_positions(std::span<const float> xyz) {
        if (xyz.size() % 3 != 0)
            throw error(TD_ERR_PARAMS, "world::set_positions: 3 floats a node");
        td_deform_report r{};
        detail::check(td_world_set_positions(w_, xyz.data(),
                                             static_cast<std::uint32_t>(xyz.size() / 3), &r),
                      "td_world_set_positions");
        return r;
    }

    // The last step's contact: its coarse tet (`TD_NO_TET` for none) and point; from the
    // thread that runs the steps.
    td_contact_at contact_at() {
        td_contact_at a{};
        detail::check(td_world_contact_at(w_, &a), "td_world_contact_at");
        return a;
    }

    // The world's servo handle.
    tetradrill::servo servo() {
        td_servo *s = nullptr;
        detail::check(td_world_servo(w_, &s), "td_world_servo");
        return tetradrill::servo(s);
    }

    // Steps, volumes, hierarchy size, saturations, region count.
    td_counters counters() const {
        td_counters c{};
        detail::check(td_world_counters(w_, &c), "td_world_counters");
        return c;
    }

    // The volume removed from each region, by label.
    std::map<std::int32_t, double> removed_by_region() const {
        std::map<std::int32_t, double> out;
        const td_counters c = counters();
        for (std::uint32_t i = 0; i < c.region_count; i++) {
            td_region r{};
            detail::check(td_world_region_at(w_, i, &r), "td_world_region_at");
            out[r.label] = r.removed_volume;
        }
        return out;
    }

    // The region labelled `label`: its material, removed volume and feel.
    td_region region(std::int32_t label) const {
        td_region r{};
        detail::check(td_world_region(w_, label, &r), "td_world_region");
        return r;
    }

    // The work the feed did on the regions it cuts: work = energy + pool + dropped.
    td_cutting cutting() const {
        td_cutting c{};
        detail::check(td_world_cutting(w_, &c), "td_world_cutting");
        return c;
    }

    // Erases the drilled material's debris (detached crumbs), as `tetradrill replay` does
    // before it writes `--surface`; the pieces erased. Between steps: O(hierarchy nodes).
    std::uint32_t remove_debris() {
        std::size_t n = 0;
        detail::check(td_world_debris_scratch(w_, &n), "td_world_debris_scratch");
        std::vector<std::uint32_t> scratch(n);
        std::uint32_t pieces = 0;
        detail::check(td_world_remove_debris(w_, scratch.data(), scratch.size(), &pieces),
                      "td_world_remove_debris");
        return pieces;
    }

    td_world *get() const noexcept { return w_; }

  private:
    world() = default;
    detail::aligned_bytes mem_{nullptr, detail::aligned_free{64}};
    td_world *w_ = nullptr;
};

// An elastic body (td_soft_*: the core's XPBD step, one material) in memory it owns, made
// from arrays (x, y, z per node; four node indices per tet, positively oriented; both copied)
// and stepped under loads, some nodes held. Move-only; its memory never moves.
class soft_body {
  public:
    // The C interface's defaults (Young's modulus 5,000, Poisson ratio 0.3, density 1,000, no
    // damping, 10 substeps of one sweep, no gravity); change fields, then make the body.
    static td_soft_params defaults() {
        td_soft_params p{};
        detail::check(td_soft_params_default(&p), "td_soft_params_default");
        return p;
    }

    soft_body(std::span<const float> positions, std::span<const std::uint32_t> tets,
              const td_soft_params &p = defaults()) {
        if (positions.size() % 3 != 0 || tets.size() % 4 != 0)
            throw error(TD_ERR_PARAMS, "soft_body: 3 floats a node and 4 indices a tet");
        n_ = static_cast<std::uint32_t>(positions.size() / 3);
        const auto t = static_cast<std::uint32_t>(tets.size() / 4);
        std::size_t size = 0, align = 0;
        detail::check(td_soft_size(n_, t, &size, &align), "td_soft_size");
        mem_ = detail::allocate(size, align);
        std::uint32_t bad = 0;
        td_status st = td_soft_init(mem_.get(), size, positions.data(), n_, tets.data(), t, &p,
                                    &s_, &bad);
        if (st == TD_ERR_MESH)
            throw item_error(st, "td_soft_init", bad);
        detail::check(st, "td_soft_init");
    }

    soft_body(soft_body &&o) noexcept
        : mem_(std::move(o.mem_)), s_(std::exchange(o.s_, nullptr)), n_(o.n_) {}
    soft_body &operator=(soft_body &&o) noexcept {
        mem_ = std::move(o.mem_);
        s_ = std::exchange(o.s_, nullptr);
        n_ = o.n_;
        return *this;
    }
    soft_body(const soft_body &) = delete;
    soft_body &operator=(const soft_body &) = delete;

    // One step of `dt` under `loads` (x, y, z of a force per node; empty for none).
    void step(float dt, std::span<const float> loads = {}) {
        if (!loads.empty() && loads.size() != 3 * std::size_t(n_))
            throw error(TD_ERR_PARAMS, "soft_body::step: loads are 3 floats a node");
        detail::check(td_soft_step(s_, dt, loads.empty() ? nullptr : loads.data()),
                      "td_soft_step");
    }

    // A field of every node, x, y, z each.
    std::vector<float> nodes(td_soft_field field) const {
        std::vector<float> out(3 * std::size_t(n_));
        detail::check(td_soft_nodes(s_, static_cast<std::uint32_t>(field), out.data(), n_),
                      "td_soft_nodes");
        return out;
    }
    std::vector<float> positions() const { return nodes(TD_SOFT_POSITIONS); }
    std::vector<float> displacements() const { return nodes(TD_SOFT_DISPLACEMENTS); }
    std::vector<float> velocities() const { return nodes(TD_SOFT_VELOCITIES); }

    // Adds `force` at `point` in tet `tet` to `loads` (3 floats a node), spread over the
    // tet's four nodes: the tool's reaction at a world's `contact_at`.
    void add_point_force(std::uint32_t tet, td_vec3 point, td_vec3 force,
                         std::span<float> loads) const {
        if (loads.size() != 3 * std::size_t(n_))
            throw error(TD_ERR_PARAMS, "soft_body::add_point_force: loads are 3 floats a node");
        detail::check(td_soft_add_point_force(s_, tet, point, force, loads.data()),
                      "td_soft_add_point_force");
    }

    // Holds or frees node `node`.
    void set_fixed(std::uint32_t node, bool fixed) {
        detail::check(td_soft_set_fixed(s_, node, fixed ? 1 : 0), "td_soft_set_fixed");
    }

    // Holds every node on or below the plane through `origin` with upward normal `up`; how
    // many.
    std::uint32_t fix_below(td_vec3 origin, td_vec3 up) {
        std::uint32_t n = 0;
        detail::check(td_soft_fix_below(s_, origin, up, &n), "td_soft_fix_below");
        return n;
    }

    // Steps, time, energies, held nodes.
    td_soft_counts counters() const {
        td_soft_counts c{};
        detail::check(td_soft_counters(s_, &c), "td_soft_counters");
        return c;
    }

    std::uint32_t node_count() const noexcept { return n_; }
    td_soft *get() const noexcept { return s_; }

  private:
    detail::aligned_bytes mem_{nullptr, detail::aligned_free{64}};
    td_soft *s_ = nullptr;
    std::uint32_t n_ = 0;
};

// A soft body's step spread over servo ticks (td_link_*): made for one deformable world and one
// soft body over the same nodes, which must outlive it. Call `tick` once a servo tick, after
// the world's step, with the force the servo gave the hand: every tick does the same share of
// the body's step and the world's update; the world takes the new positions at each cycle's
// last tick. Owns its memory.
class link {
  public:
    link(world &w, soft_body &b, std::uint32_t ticks, float dt) : w_(w.get()), b_(b.get()) {
        std::size_t size = 0, align = 0;
        detail::check(td_link_size(b.node_count(), &size, &align), "td_link_size");
        mem_ = detail::allocate(size, align);
        detail::check(td_link_init(mem_.get(), size, w_, b_, ticks, dt, &l_), "td_link_init");
    }

    link(link &&o) noexcept
        : mem_(std::move(o.mem_)), l_(std::exchange(o.l_, nullptr)), w_(o.w_), b_(o.b_) {}
    link &operator=(link &&o) noexcept {
        mem_ = std::move(o.mem_);
        l_ = std::exchange(o.l_, nullptr);
        w_ = o.w_;
        b_ = o.b_;
        return *this;
    }
    link(const link &) = delete;
    link &operator=(const link &) = delete;

    // One servo tick whose force on the hand was `force`; what it did (`committed` 1 on a
    // cycle's last tick).
    td_link_report tick(td_vec3 force) {
        td_link_report r{};
        detail::check(td_link_tick(l_, w_, b_, force, &r), "td_link_tick");
        return r;
    }

    // Ticks a cycle, units a tick and a cycle, steps committed, late cycles.
    td_link_counts counters() const {
        td_link_counts c{};
        detail::check(td_link_counters(l_, &c), "td_link_counters");
        return c;
    }

    td_link *get() const noexcept { return l_; }

  private:
    detail::aligned_bytes mem_{nullptr, detail::aligned_free{64}};
    td_link *l_ = nullptr;
    td_world *w_ = nullptr;
    td_soft *b_ = nullptr;
};

// The drilled surface of a world in buffers an engine uploads: stable triangle slots (slot `s`
// is vertices 3s, 3s+1, 3s+2 of every buffer), written only where the surface changed. Owns its
// memory and its buffers; keeps a pointer to its world, which must outlive it. Update it from
// the simulation's thread, between steps.
//
// Made with `smooth_normals`, its normals are each corner's smooth normal
// (td_surface_init_smooth), else each face's own.
struct smooth_normals {
    // Faces further apart than this are not averaged (0: the core's default, 75 degrees).
    float crease_degrees = 0.0f;
};

class surface {
  public:
    surface(world &w, std::uint32_t max_triangles, std::uint32_t range_capacity = 64)
        : surface(w, max_triangles, nullptr, range_capacity) {}

    surface(world &w, std::uint32_t max_triangles, smooth_normals smooth,
            std::uint32_t range_capacity = 64)
        : surface(w, max_triangles, &smooth, range_capacity) {}

    surface(surface &&) noexcept = default;
    surface &operator=(surface &&) noexcept = default;
    surface(const surface &) = delete;
    surface &operator=(const surface &) = delete;

    // One update of at most about `budget` work units; `ranges()` then says which slots
    // changed. `pending` 0 in the report: the buffers hold the drilled surface exactly.
    td_surface_report update(std::uint32_t budget) {
        td_surface_buffers b{positions_.data(), normals_.data(), labels_.data(),
                             indices_.data(),   ranges_.data(),  std::uint32_t(ranges_.size())};
        detail::check(td_surface_update(s_, world_, budget, &b, &last_), "td_surface_update");
        return last_;
    }

    // Updates until the buffers hold the drilled surface (at most `max_calls` calls of
    // `budget` each); the last report.
    td_surface_report update_all(std::uint32_t budget, std::uint32_t max_calls = 1u << 20) {
        for (std::uint32_t i = 0; i < max_calls; i++)
            if (update(budget).pending == 0)
                break;
        return last_;
    }

    // The slot runs the last update wrote.
    std::span<const td_slot_range> ranges() const noexcept {
        return std::span(ranges_).first(last_.ranges);
    }
    // x, y, z per vertex, three vertices a slot.
    std::span<const float> positions() const noexcept { return positions_; }
    // The corner's smooth normal on each vertex (made with `smooth_normals`), else the face's
    // outward unit normal.
    std::span<const float> normals() const noexcept { return normals_; }
    // Whether the normals are smooth.
    bool smooth() const noexcept { return smooth_; }
    // The smooth normals' shared vertices and saturations (all 0 without them).
    td_smooth_stats smooth_stats() const {
        td_smooth_stats st{};
        detail::check(td_surface_smooth_stats(s_, &st), "td_surface_smooth_stats");
        return st;
    }
    // The region label on each vertex.
    std::span<const std::int32_t> labels() const noexcept { return labels_; }
    // Three vertex indices a slot; a free slot's are 0, 0, 0.
    std::span<const std::uint32_t> indices() const noexcept { return indices_; }

    // The live triangles as a Wavefront OBJ (a vertex triple and a face each; with smooth
    // normals a normal triple too, `vn`, and faces `f a//a b//b c//c`).
    std::string to_obj() const {
        std::string out = "# tetradrill drilled surface: visible faces\n";
        std::size_t written = 0;
        char line[128];
        for (std::size_t t = 0; t < std::size_t(n_); t++) {
            const std::uint32_t *i = &indices_[3 * t];
            if (i[0] == i[1] && i[1] == i[2])
                continue; // a free slot
            for (int k = 0; k < 3; k++) {
                const float *v = &positions_[3 * std::size_t(i[k])];
                std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", double(v[0]), double(v[1]),
                              double(v[2]));
                out += line;
            }
            if (smooth_) {
                for (int k = 0; k < 3; k++) {
                    const float *v = &normals_[3 * std::size_t(i[k])];
                    std::snprintf(line, sizeof line, "vn %.9g %.9g %.9g\n", double(v[0]),
                                  double(v[1]), double(v[2]));
                    out += line;
                }
                const std::size_t a = 3 * written + 1;
                std::snprintf(line, sizeof line, "f %zu//%zu %zu//%zu %zu//%zu\n", a, a, a + 1,
                              a + 1, a + 2, a + 2);
            } else {
                std::snprintf(line, sizeof line, "f %zu %zu %zu\n", 3 * written + 1,
                              3 * written + 2, 3 * written + 3);
            }
            out += line;
            written++;
        }
        return out;
    }

  private:
    surface(world &w, std::uint32_t max_triangles, const smooth_normals *smooth,
            std::uint32_t range_capacity)
        : world_(w.get()), n_(max_triangles), smooth_(smooth != nullptr),
          positions_(9 * std::size_t(max_triangles)), normals_(9 * std::size_t(max_triangles)),
          labels_(3 * std::size_t(max_triangles)), indices_(3 * std::size_t(max_triangles)),
          ranges_(range_capacity) {
        std::size_t size = 0, align = 0;
        if (smooth) {
            detail::check(td_surface_smooth_size(world_, n_, &size, &align),
                          "td_surface_smooth_size");
            mem_ = detail::allocate(size, align);
            detail::check(td_surface_init_smooth(mem_.get(), size, world_, n_,
                                                 smooth->crease_degrees, &s_),
                          "td_surface_init_smooth");
        } else {
            detail::check(td_surface_size(world_, n_, &size, &align), "td_surface_size");
            mem_ = detail::allocate(size, align);
            detail::check(td_surface_init(mem_.get(), size, world_, n_, &s_), "td_surface_init");
        }
    }

    td_world *world_;
    std::uint32_t n_;
    bool smooth_;
    detail::aligned_bytes mem_{nullptr, detail::aligned_free{64}};
    td_surface *s_ = nullptr;
    std::vector<float> positions_, normals_;
    std::vector<std::int32_t> labels_;
    std::vector<std::uint32_t> indices_;
    std::vector<td_slot_range> ranges_;
    td_surface_report last_{};
};

} // namespace tetradrill

#endif
