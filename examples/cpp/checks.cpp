// Checks of the C++ wrapper's own behaviour (scripts/cpp-example.sh runs it): errors become
// exceptions that carry the status and the line, byte or item at fault; a world moves without
// its memory moving; its servo runs on a thread of its own beside the steps; a soft body
// holds its base and sags, and a deformable world follows it under the burr.
//
//   checks SCRATCH_DIR
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "tetradrill.hpp"

static int failures = 0;

static void expect(bool ok, const char *what) {
    std::printf("%s: %s\n", ok ? "ok" : "FAIL", what);
    failures += ok ? 0 : 1;
}

// The unit cube as 5 tets (8 nodes).
static const std::vector<float> cube_xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0,
                                            0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
static const std::vector<std::uint32_t> cube_tets = {0, 1, 2, 4, 1, 3, 2, 7, 1, 2, 4, 7,
                                                     1, 4, 5, 7, 2, 4, 6, 7};

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "checks: usage: checks SCRATCH_DIR\n");
        return 2;
    }
    const std::string dir = argv[1];
    // A mesh file with a bad line: the exception names the file and the line.
    {
        std::ofstream(dir + "/one.node") << "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
        std::ofstream(dir + "/one.ele") << "1 4 0\n0 0 1 2 9\n";
        bool thrown = false;
        try {
            tetradrill::mesh_file f(dir + "/one.node");
        } catch (const tetradrill::file_error &e) {
            thrown = e.status() == TD_ERR_FILE && e.line() == 2 &&
                     std::string(e.what()).find("one.ele:2:") != std::string::npos;
        }
        expect(thrown, "a bad mesh file throws file_error naming its file and line 2");
    }
    auto p = tetradrill::params::defaults(8, 5);
    p.hierarchy_capacity = 4096;
    p.radius = 0.2f;
    // A mesh the build refuses: the exception names the tet.
    {
        std::vector<std::uint32_t> bad = cube_tets;
        bad[4 * 3 + 1] = 99;
        bool thrown = false;
        try {
            tetradrill::world w(p, cube_xyz, bad);
        } catch (const tetradrill::item_error &e) {
            thrown = e.status() == TD_ERR_MESH && e.item() == 3;
        }
        expect(thrown, "a node out of range throws item_error naming tet 3");
    }
    // Arrays of the wrong length are refused before the C call.
    {
        bool thrown = false;
        try {
            tetradrill::world w(p, std::span(cube_xyz).first(21), cube_tets);
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_PARAMS;
        }
        expect(thrown, "short arrays throw error(TD_ERR_PARAMS)");
    }
    // A region's feel reads back, survives a later set_region, and is refused once stepped.
    {
        tetradrill::world f(p, cube_xyz, cube_tets);
        f.set_region_feel(0, 0.5f, 40.f, 0.2f);
        f.set_region(0, 0.f, 1.f);
        const td_region r = f.region(0);
        expect(r.vibration == 0.5f && r.cutting_energy == 40.f && r.friction == 0.2f &&
                   r.threshold == 1.f,
               "set_region keeps the feel set before it");
        bool thrown = false;
        try {
            f.set_region_feel(0, 0.f, -1.f, 0.f);
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_PARAMS;
        }
        expect(thrown, "a negative cutting energy throws error(TD_ERR_PARAMS)");
        f.tick({0.5f, 0.5f, 1.1f}, 1);
        const td_cutting c = f.cutting();
        expect(c.work == 0.0 && c.energy == 0.0, "no work done in the air");
        thrown = false;
        try {
            f.set_region_feel(0, 0.f, 0.f, 0.f);
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_STARTED;
        }
        expect(thrown, "a feel after the first step throws error(TD_ERR_STARTED)");
        thrown = false;
        try {
            f.servo().set_spin({std::numeric_limits<float>::infinity(), 0.f, 0.f});
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_INPUT;
        }
        expect(thrown, "an infinite spin throws error(TD_ERR_INPUT)");
        f.servo().set_spin({0.f, 0.f, -1.f});
    }
    // A world moved keeps its memory: the servo taken before the move still works after it.
    tetradrill::world a(p, cube_xyz, cube_tets);
    tetradrill::servo s = a.servo();
    tetradrill::world w = std::move(a);
    expect(a.get() == nullptr && w.get() != nullptr, "a moved-from world holds nothing");
    // The servo on its own thread beside the steps: a press into the top face. Only that
    // thread calls the servo until it is joined.
    std::atomic<bool> done{false};
    std::atomic<int> servo_errors{0};
    std::atomic<std::uint32_t> step_seen{0};
    float top_force = 0.f;
    std::thread servo_thread([&] {
        while (!done.load()) {
            try {
                const float z = s.force({0.5f, 0.5f, 1.1f}).z;
                const std::uint32_t step = s.counters().step;
                if (step == 2000)
                    top_force = z;
                step_seen = step;
            } catch (const tetradrill::error &) {
                servo_errors++;
                return;
            }
        }
    });
    for (int i = 0; i < 2000; i++)
        w.simulate({0.5f, 0.5f, 1.1f}, 0);
    while (step_seen.load() != 2000 && servo_errors.load() == 0)
        std::this_thread::yield();
    done = true;
    servo_thread.join();
    expect(servo_errors.load() == 0, "every servo call on the other thread succeeded");
    expect(s.counters().step == 2000, "the servo renders from the last published step");
    expect(top_force > 0.f, "the press into the top face pushes up (+z)");
    // A bad pose is an exception, not a force.
    bool thrown = false;
    try {
        w.tick({std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f}, 0);
    } catch (const tetradrill::error &e) {
        thrown = e.status() == TD_ERR_INPUT;
    }
    expect(thrown, "a NaN pose throws error(TD_ERR_INPUT)");
    // A soft body: the cube (its fifth tet turned positive) held at its base sags under
    // gravity; a tet turned inside out is named.
    {
        std::vector<std::uint32_t> tets = cube_tets;
        std::swap(tets[4 * 4 + 1], tets[4 * 4 + 2]);
        auto sp = tetradrill::soft_body::defaults();
        sp.gravity = {0.f, 0.f, -9.81f};
        tetradrill::soft_body b(cube_xyz, tets, sp);
        const std::uint32_t held = b.fix_below({0.f, 0.f, 0.f}, {0.f, 0.f, 1.f});
        for (int i = 0; i < 50; i++)
            b.step(0.004f);
        tetradrill::soft_body moved(std::move(b));
        const auto d = moved.displacements();
        bool base_still = true, top_sags = true;
        for (std::uint32_t k = 0; k < 8; k++) {
            const bool base = cube_xyz[3 * k + 2] == 0.f;
            base_still = base_still && (!base || (d[3 * k] == 0.f && d[3 * k + 2] == 0.f));
            top_sags = top_sags && (base || d[3 * k + 2] < 0.f);
        }
        const auto c = moved.counters();
        expect(held == 4 && c.fixed_nodes == 4 && c.steps == 50,
               "a soft body holds its base's 4 nodes over 50 steps");
        expect(base_still && top_sags, "its base stays and its top sags under gravity");
        bool thrown = false;
        try {
            tetradrill::soft_body inverted(cube_xyz, cube_tets, sp);
        } catch (const tetradrill::item_error &e) {
            thrown = e.status() == TD_ERR_MESH && e.item() == 4;
        }
        expect(thrown, "a tet inside out throws item_error naming tet 4");
        thrown = false;
        try {
            moved.step(0.004f, std::vector<float>(5, 0.f));
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_PARAMS;
        }
        expect(thrown, "loads of the wrong length throw error(TD_ERR_PARAMS)");
        // The burr pressed into the top of a deformable world over the same arrays, its
        // reaction loading the body held at its base: the top gives way, so the contact
        // point sinks below z = 1 and the force falls below a rigid world's.
        auto dp = p;
        dp.deformable = 1;
        tetradrill::world soft_world(dp, cube_xyz, tets);
        tetradrill::world rigid(p, cube_xyz, tets);
        auto soft_sp = tetradrill::soft_body::defaults();
        soft_sp.young = 2000.f;
        soft_sp.density = 1.f;
        soft_sp.damping = 20.f;
        tetradrill::soft_body body(cube_xyz, tets, soft_sp);
        body.fix_below({0.f, 0.f, 0.f}, {0.f, 0.f, 1.f});
        std::vector<float> loads(3 * 8, 0.f);
        const td_vec3 at{0.4f, 0.45f, 1.f + p.radius - 0.02f};
        td_vec3 f{}, fr{};
        for (int i = 1; i <= 500; i++) {
            f = soft_world.tick(at, 0);
            fr = rigid.tick(at, 0);
            const td_contact_at hit = soft_world.contact_at();
            if (hit.tet != TD_NO_TET)
                body.add_point_force(hit.tet, hit.point, {-f.x, -f.y, -f.z}, loads);
            if (i % 5 == 0) {
                for (float &l : loads)
                    l /= 5.f;
                body.step(0.005f, loads);
                std::fill(loads.begin(), loads.end(), 0.f);
                soft_world.set_positions(body.positions());
            }
        }
        const td_contact_at hit = soft_world.contact_at();
        std::printf("dent %.5f, force %.4f against the rigid world's %.4f\n", 1.f - hit.point.z,
                    f.z, fr.z);
        expect(hit.tet != TD_NO_TET && hit.point.z < 1.f - 1e-3f && f.z > 0.f && f.z < fr.z,
               "a deformable world follows the soft body its burr presses");
        // The same press with the body's step spread over the ticks (a link, a step every 5
        // ticks): the world gives way as well, and no tick does more than its share and one
        // tet solve (18 units).
        tetradrill::world linked_world(dp, cube_xyz, tets);
        tetradrill::soft_body linked_body(cube_xyz, tets, soft_sp);
        linked_body.fix_below({0.f, 0.f, 0.f}, {0.f, 0.f, 1.f});
        tetradrill::link spread(linked_world, linked_body, 5, 0.001f);
        const td_link_counts lc = spread.counters();
        std::uint32_t most = 0, commits = 0;
        td_vec3 fl{};
        for (int i = 1; i <= 500; i++) {
            fl = linked_world.tick(at, 0);
            const td_link_report r = spread.tick(fl);
            most = std::max(most, r.units);
            commits += r.committed;
        }
        const td_contact_at lhit = linked_world.contact_at();
        std::printf("linked: dent %.5f, force %.4f; %u steps, %u units a tick, at most %u\n",
                    1.f - lhit.point.z, fl.z, commits, lc.units_per_tick, most);
        expect(commits == 100 && spread.counters().late == 0 && most < lc.units_per_tick + 18,
               "a link commits a step every 5 ticks, each tick within its share and a tet solve");
        expect(lhit.tet != TD_NO_TET && lhit.point.z < 1.f - 1e-3f && fl.z > 0.f && fl.z < fr.z,
               "a linked deformable world follows the soft body its burr presses");
        thrown = false;
        try {
            linked_body.step(0.005f);
            spread.tick(fl);
            linked_body.step(0.005f);
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_BUSY;
        }
        expect(thrown, "a linked body's own step in a cycle throws error(TD_ERR_BUSY)");
        thrown = false;
        try {
            rigid.set_positions(body.positions());
        } catch (const tetradrill::error &e) {
            thrown = e.status() == TD_ERR_RIGID;
        }
        expect(thrown, "a rigid world's set_positions throws error(TD_ERR_RIGID)");
    }
    {
        // A tool driven into a wall of 200 N/m clamped at 8 N 1 mm a tick (a reversed motor)
        // trips the passivity observer, which then sends zero; recovered, the force passes.
        tetradrill::passivity obs;
        td_vec3 out{};
        for (int tick = 0; tick < 60; tick++) {
            const float d = 0.001f * float(tick);
            out = obs.step({0.f, 0.f, -d}, {0.f, 0.f, std::min(200.f * d, 8.f)},
                           tetradrill::passivity::penalty(d, 200.f, 8.f));
        }
        const td_passivity_counts pc = obs.counters();
        expect(pc.tripped == 1 && pc.trips == 1 && out.z == 0.f,
               "a tool driven past the force limit trips the observer (zero force)");
        obs.recover();
        out = obs.step({0.f, 0.f, 0.1f}, {0.f, 0.f, 0.5f}, std::nullopt);
        expect(out.z == 0.5f && obs.counters().tripped == 0, "recovered, the force passes");
    }
    std::printf("checks: %s\n", failures == 0 ? "OK" : "FAILED");
    return failures == 0 ? 0 : 1;
}
