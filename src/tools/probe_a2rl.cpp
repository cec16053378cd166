#include <cstdio>
#include <cstdlib>
#include "flexcloud/georeference.h"
#include "flexcloud/io/text_io.h"
using namespace flexcloud;
int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : "/work/shared/data/a2rl";
  DriveInput in;
  in.poses = readTumFile(dir + "/slam_poses_tum.txt");
  in.local_gnss = readLocalGnssFile(dir + "/gnss_local_at_poses.txt");
  for (int mode : {0}) {
    for (int n : {10, 50, 100, 200}) {
      Params p;
      p.control_points = n;
      
      if (argc > 2) p.refine_fraction = atof(argv[2]);
      auto r = georeference(in, p);
      std::printf("%s n=%d cps=%zu matched=%zu  aligned mae %.2f max %.2f | rs mae %.3f std %.3f max %.3f rmse %.3f scale %.5f tets %zu\n",
                  "rigid", n, r.control_points.points.size(), r.poses_matched,
                  r.metrics_aligned.mae, r.metrics_aligned.max, r.metrics_rubbersheet.mae,
                  r.metrics_rubbersheet.std, r.metrics_rubbersheet.max, r.metrics_rubbersheet.rmse,
                  r.scale, r.sheet->numTetrahedra());
    }
  }
}
