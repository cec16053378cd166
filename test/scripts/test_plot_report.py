"""scripts/plot_report.py's table handling: the GNSS rows matched to the trajectory's stamps, and
the thinning of the trajectory's markers, against plain Python; and what the picture draws from
the pose sigmas."""
import importlib.util
import pathlib
import tempfile
import unittest

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("plot_report", ROOT / "scripts" / "plot_report.py")
plot_report = importlib.util.module_from_spec(spec)
spec.loader.exec_module(plot_report)


class PlotReportTables(unittest.TestCase):
    def test_rows_match_by_the_stamp_to_the_microsecond(self):
        rng = np.random.default_rng(3)
        times = 1.7e9 + np.round(np.sort(rng.uniform(0, 600, 3000)), 6)
        shuffled = rng.permutation(len(times))
        times = times[shuffled]  # any order
        wanted = np.concatenate([times[::7] + 4e-7, times[::11] - 3e-7, [1.7e9 - 1, 1.8e9],
                                 times[5:6] + 2e-6])
        index = {round(t, 6): i for i, t in enumerate(times)}
        expected = [index.get(round(t, 6), -1) for t in wanted]
        got = plot_report.matching_rows(times, wanted)
        self.assertEqual(got.tolist(), expected)
        self.assertEqual(got[-3:].tolist(), [-1, -1, -1])  # before, after, 2 us off
        self.assertEqual(plot_report.matching_rows(np.zeros(0), wanted[:3]).tolist(), [-1] * 3)

    def test_thinning_keeps_at_most_the_asked_rows_and_every_row_of_short_drives(self):
        for n, most, kept in [(100, 4000, 100), (4000, 4000, 4000), (4001, 4000, 2001),
                              (16667, 4000, 3334)]:
            self.assertEqual(len(range(n)[plot_report.thinned(n, most)]), kept)

    def test_rejected_down_weighted_and_degraded_fixes_are_told_apart(self):
        rows = ["# header", "10.0 1 2 3 0.01 0.9 used 0.01 0.02 0 0 0",
                "10.2 4 5 6 3.50 0.0 outlier 0.01 0.02 0 0 0",
                "10.4 7 8 9 0.40 0.05 used 2.0 4.0 0 0 0", "10.5 7 8 9 0.02 0.3 used 2.0 4.0 0 0 0",
                "10.6 1 1 1 0.30 0.8 above_std_threshold 2.0 4.0 0 0 0",
                "10.8 2 2 2 0.30 0.49 above_std_threshold 2.0 4.0 0 0 0",
                "11.0 3 3 3 0.00 1.0 excluded_range 0.01 0.02 0 0 0"]
        with tempfile.NamedTemporaryFile("w", suffix=".txt") as f:
            f.write("\n".join(rows) + "\n")
            f.flush()
            judged = plot_report.judged_fixes(f.name)
        self.assertEqual(judged["rejected"].tolist(), [[10.2, 4, 5]])
        self.assertEqual(judged["down-weighted"].tolist(), [[10.4, 7, 8]])
        self.assertEqual(judged["above threshold"][:, 0].tolist(), [10.6, 10.8])
        self.assertEqual(plot_report.judged_fixes("/nonexistent")["rejected"].shape, (0, 3))


def write_tum(path, rows):
    with open(path, "w") as f:
        f.write("# TUM\n")
        for r in rows:
            f.write(" ".join(f"{v:.6f}" for v in r) + "\n")


class PlotReportSigma(unittest.TestCase):
    def run_plot(self, sigma_rows):
        """A straight 100-pose drive drawn with `sigma_rows` as trajectory_sigma.txt (None: no
        file); the figure's axes by title."""
        with tempfile.TemporaryDirectory() as d:
            poses = [[0.1 * i, float(i), 0.0, 0.0, 0, 0, 0, 1] for i in range(100)]
            write_tum(f"{d}/trajectory_aligned.txt", [[*p[:2], 0.5, *p[3:]] for p in poses])
            write_tum(f"{d}/trajectory_rubbersheet.txt", poses)
            write_tum(f"{d}/trajectory_gnss.txt", poses[::2])
            if sigma_rows is not None:
                with open(f"{d}/trajectory_sigma.txt", "w") as f:
                    f.write("# stamp sigma_h_m sigma_v_m\n")
                    for r in sigma_rows:
                        f.write(f"{r[0]:.6f} {r[1]:.4f} {r[2]:.4f}\n")
            plot_report.plt.close("all")
            self.assertEqual(plot_report.main(d), 0)
            self.assertTrue(pathlib.Path(f"{d}/report.png").stat().st_size > 10000)
            return {a.get_title(): a for a in plot_report.plt.gcf().axes}

    def test_the_band_is_two_point_four_five_sigma_along_the_drive(self):
        sigma = [[0.1 * i, 0.01 + 0.001 * i, 0.02] for i in range(100)]
        axes = self.run_plot(sigma)
        truth = axes["How far from the truth: 95 % of the poses within"]
        band = truth.collections[0].get_paths()[0].vertices
        self.assertAlmostEqual(band[:, 1].max(), 2.45 * 0.109, places=4)
        vertical = truth.lines[0].get_ydata()
        self.assertAlmostEqual(float(np.max(vertical)), 1.96 * 0.02, places=4)
        top = axes["Corrected trajectory, top view (ENU)"]
        colours = top.collections[0].get_array()
        self.assertAlmostEqual(float(colours.max()), 0.109, places=4)  # coloured by the sigma
        # The GNSS line lies above the trajectory's markers.
        gnss = [line for line in top.lines if line.get_label() == "GNSS at the poses"][0]
        self.assertGreater(gnss.get_zorder(), top.collections[0].get_zorder())

    def test_without_the_sigmas_the_top_view_shows_the_correction(self):
        axes = self.run_plot(None)
        truth = axes["How far from the truth: 95 % of the poses within"]
        self.assertEqual(len(truth.collections), 0)
        top = axes["Corrected trajectory, top view (ENU)"]
        self.assertAlmostEqual(float(top.collections[0].get_array().max()), 0.5, places=4)


if __name__ == "__main__":
    unittest.main()
