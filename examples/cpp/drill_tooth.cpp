// Drills the premolar's access cavity through tetradrill's C++ wrapper (ffi/include/
// tetradrill.hpp): the tooth read from its mesh file with its three materials (enamel,
// dentin, pulp), the burr driven along the scripted access path, a tick a millisecond, as
// `tetradrill replay --scenario builtin:firmware-tooth` runs it, its drilled surface kept in
// buffers an engine would upload (updated a frame at a time, 60 a second). Prints the force
// digest and the volume removed from each region and writes the surface as OBJ;
// scripts/cpp-example.sh compares them with the host's (`replay --json`, `--surface`).
//
//   drill_tooth MESH_FILE OUT.obj
//
// Every setting is the host scenario's (host-runner/src/scenario), written as the host derives
// it: doubles converted to float.
#include <cinttypes>
#include <cstdio>
#include <exception>

#include "tetradrill.hpp"

int main(int argc, char **argv) {
    if (argc != 3) {
        std::fprintf(stderr, "drill_tooth: usage: drill_tooth MESH_FILE OUT.obj\n");
        return 2;
    }
    try {
        tetradrill::mesh_file tooth(argv[1]);
        td_params p = tetradrill::params::defaults(tooth.node_count(), tooth.tet_count());
        // builtin:firmware-tooth: a 0.7 mm burr, metres and newtons ...
        p.radius = static_cast<float>(0.0007);
        p.reach = 0.5f * p.radius;
        p.stiffness = static_cast<float>(6000.0);
        p.damping = static_cast<float>(0.5);
        p.max_force = static_cast<float>(8.0);
        p.dt = static_cast<float>(1e-3);
        p.switch_time = static_cast<float>(16.0 / 1000.0);
        p.servo_lag = 1; // the firmware's release rule
        // ... with the firmware's limits and the capacities that hold the whole path.
        p.max_depth = 4;
        p.min_area = 0.f;
        p.budget_per_tick = 300;
        p.contact_search_nodes = 64;
        p.tick_budget = 0;
        p.hierarchy_capacity = 60000;
        p.pending_capacity = 16384;
        p.candidate_capacity = 3072;
        p.max_cells = 4096;
        p.zone_gather_work = 2000;
        p.region_capacity = 3;

        tetradrill::world world(p, tooth);
        // The tooth's materials (host-runner/src/setup/materials.rs, tooth_regions): hardness
        // in N s per cubic metre, threshold in N, stiffness in N per metre.
        world.set_region(1, static_cast<float>(1.0e9), 1.f, static_cast<float>(10000.0)); // enamel
        world.set_region(2, static_cast<float>(2.0e8), 0.5f, static_cast<float>(6000.0)); // dentin
        world.set_region(3, static_cast<float>(4.0e6), 0.1f, static_cast<float>(1000.0)); // pulp

        // The drilled surface with smooth normals: up to 65,536 triangles, 4,096 work units a
        // 60 Hz frame.
        tetradrill::surface shown(world, 1u << 16, tetradrill::smooth_normals{});
        std::uint64_t uploaded = 0;
        const std::uint32_t ticks = td_script_ticks(TD_SCRIPT_TOOTH_ACCESS);
        float force_max = 0.f;
        for (std::uint32_t i = 0; i < ticks; i++) {
            td_vec3 at{};
            std::uint32_t buttons = 0;
            tetradrill::detail::check(td_script_pose(TD_SCRIPT_TOOTH_ACCESS, i, &at, &buttons),
                                      "td_script_pose");
            const td_vec3 f = world.tick(at, buttons);
            const float m = f.x * f.x + f.y * f.y + f.z * f.z;
            force_max = m > force_max ? m : force_max;
            if (i % 16 == 0) {
                shown.update(4096);
                for (const td_slot_range &r : shown.ranges())
                    uploaded += r.count; // an engine uploads these slots
            }
        }
        // As replay does before it writes its surface: the debris erased, the surface brought
        // up to date.
        const std::uint32_t debris = world.remove_debris();
        const td_surface_report last = shown.update_all(4096);
        if (last.pending != 0 || last.dropped != 0)
            throw tetradrill::error(TD_ERR_TOO_SMALL, "the surface's buffers are too small");
        std::FILE *obj = std::fopen(argv[2], "w");
        const std::string text = shown.to_obj();
        if (!obj || std::fwrite(text.data(), 1, text.size(), obj) != text.size() || std::fclose(obj) != 0) {
            std::fprintf(stderr, "drill_tooth: %s: cannot write\n", argv[2]);
            return 1;
        }
        const td_counters c = world.counters();
        const td_servo_counts s = world.servo().counters();
        std::printf("ticks=%" PRIu64 "\n", s.servo_ticks);
        std::printf("removed_volume=%.6e\n", c.removed_volume);
        std::printf("visible_faces=%u\n", static_cast<unsigned>(c.visible_faces));
        std::printf("debris_pieces=%u\n", static_cast<unsigned>(debris));
        std::printf("surface_triangles=%u\n", static_cast<unsigned>(last.live));
        std::printf("slots_uploaded=%" PRIu64 "\n", uploaded);
        for (const auto &[label, v] : world.removed_by_region())
            std::printf("removed_by_region.%d=%.6e\n", static_cast<int>(label), v);
        std::printf("force_digest=%016" PRIx64 "\n", s.force_digest);
    } catch (const tetradrill::file_error &e) {
        std::fprintf(stderr, "drill_tooth: %s\n", e.what());
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "drill_tooth: %s\n", e.what());
        return 1;
    }
    return 0;
}
