#include <chrono>
#include <cstdio>
#include <cstdlib>
#include "flexcloud/georeference.h"
#include "flexcloud/metrics.h"
#include "flexcloud/sim/drive_simulator.h"
using namespace flexcloud;
int main(int argc, char** argv) {
  sim::SimParams sp;
  sp.loop = argc > 1 ? atoi(argv[1]) : 1;
  sp.seed = argc > 2 ? atoi(argv[2]) : 1;
  sp.map_points = 100000;
  auto t0 = std::chrono::steady_clock::now();
  auto d = sim::simulateDrive(sp);
  double ts = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  DriveInput in; in.fixes = d.fixes; in.poses = d.slam;
  // truth trajectory error of the slam before alignment
  for (double rf : {0.0, 0.5, 0.75}) for (int cm : {0}) {
    Params p; p.control_points = argc > 3 ? atoi(argv[3]) : 200; p.refine_fraction = rf; 
    auto r = georeference(in, p);
    const EnuFrame enu(*r.datum); const EnuFrame truth_frame(d.datum);
    ErrorAccumulator a, b, bg, bw, bp; 
    for (size_t i = 0; i < d.map.slam.size(); ++i) {
      // truth points are in the simulator's datum frame; result datum = first fix
      auto g = truth_frame.toGeodetic(d.map.truth[i]); Eigen::Vector3d t = enu.toEnu(g.lat, g.lon, g.alt);
      a.add((r.T_enu_map * d.map.slam[i] - t).norm());
      double e = (r.sheet->transform(d.map.slam[i]) - t).norm(); b.add(e);
      (d.map.label[i]==1?bg:d.map.label[i]==2?bw:bp).add(e);
    }
    ErrorAccumulator tr; for (size_t i = 0; i < d.truth.size(); ++i) { auto g = truth_frame.toGeodetic(d.truth[i].position); tr.add((r.rubbersheet[i].position - enu.toEnu(g.lat,g.lon,g.alt)).norm()); }
    std::printf("loop=%d rf=%.2f %s cps=%zu | traj-vs-gnss rs mae %.3f max %.3f | traj-vs-truth rmse %.3f | map rigid rmse %.2f max %.2f | map rs rmse %.3f max %.3f (ground %.3f wall %.3f pole %.3f) scale %.5f sim %.1fs\n",
      sp.loop, rf, "rigid", r.control_points.points.size(), r.metrics_rubbersheet.mae, r.metrics_rubbersheet.max, tr.stats().rmse, a.stats().rmse, a.stats().max, b.stats().rmse, b.stats().max, bg.stats().rmse, bw.stats().rmse, bp.stats().rmse, r.scale, ts);
  }
}
