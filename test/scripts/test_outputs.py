#!/usr/bin/env python3
"""The outputs other tools take (issue 10), checked with readers that are not flexcloud's own:
Autoware tiles and their metadata read back with numpy, every projector's points reprojected
with pyproj (PROJ), the LAS read by loaders.gl under Node.js, the CRS from its WKT by pyproj,
trajectories.geojson and report.png checked as files, --to-ll against pyproj, and bad values
refused in one line without an output folder.

Run by scripts/test.sh after the build (python3 -m xmlrunner discover -p 'test_*.py').
"""
import json
import os
import pathlib
import re
import shutil
import struct
import subprocess
import tempfile
import unittest

import numpy as np
import yaml
from pyproj import CRS, Transformer

ROOT = pathlib.Path(__file__).resolve().parents[2]
WS = pathlib.Path(os.environ.get("FLEXCLOUD_WS", ROOT / ".ws"))
BIN = WS / "devel" / "lib" / "flexcloud"
DATUM = (48.262, 11.667, 480.0)  # the simulator's datum: its truth is in this ENU frame
SAMPLE = 400  # points checked per comparison


def run(*args, check=True):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"{args[0]} exited {p.returncode}: {p.stderr[-2000:]}")
    return p


def read_pcd(path):
    """A binary PCD as a numpy structured array (padding fields named _0, _1, ...)."""
    raw = pathlib.Path(path).read_bytes()
    header = {}
    pos = 0
    while True:
        end = raw.index(b"\n", pos)
        line = raw[pos:end].decode().strip()
        pos = end + 1
        if not line or line.startswith("#"):
            continue
        key, *values = line.split()
        header[key] = values
        if key == "DATA":
            break
    assert header["DATA"] == ["binary"], f"{path}: not binary"
    kinds = {"F": "f", "U": "u", "I": "i"}
    dtype = []
    for k, (name, size, kind, count) in enumerate(
            zip(header["FIELDS"], header["SIZE"], header["TYPE"], header["COUNT"])):
        name = f"_{k}" if name == "_" else name
        base = f"<{kinds[kind]}{size}"
        dtype.append((name, base) if int(count) == 1 else (name, base, (int(count),)))
    n = int(header["POINTS"][0])
    return np.frombuffer(raw, dtype=np.dtype(dtype), count=n, offset=pos)


def enu_to_geodetic(datum):
    """ENU about the datum -> lon, lat, ellipsoidal height, through PROJ's topocentric."""
    lat, lon, alt = datum
    return Transformer.from_pipeline(
        f"+proj=pipeline +step +inv +proj=topocentric +ellps=WGS84 +lat_0={lat} +lon_0={lon} "
        f"+h_0={alt} +step +inv +proj=cart +ellps=WGS84")


def utm_epsg(lat, lon):
    return (32600 if lat >= 0 else 32700) + int((lon + 180) // 6) + 1


def to_utm(datum, xyz):
    """ENU points (N x 3) -> easting, northing, height in the datum's UTM zone (pyproj)."""
    lon, lat, h = enu_to_geodetic(datum).transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
    utm = Transformer.from_crs("EPSG:4326", f"EPSG:{utm_epsg(datum[0], datum[1])}",
                               always_xy=True)
    e, n = utm.transform(lon, lat)
    return np.column_stack([e, n, h])


def xyz(points):
    return np.column_stack([points["x"], points["y"], points["z"]]).astype(np.float64)


# ---- the Autoware map as Autoware's loaders read it -----------------------------------------
# Written from autoware.universe's map_projection_loader (load_info_from_yaml) and
# pointcloud_map_loader (load_pcd_metadata), not from flexcloud's writer.

def autoware_projector_info(path):
    """map_projector_info.yaml as map_projection_loader takes it: for LocalCartesian,
    LocalCartesianUTM and TransverseMercator the origin's latitude and longitude, and altitude 0
    whatever the file says (map z is the height in the vertical datum); MGRS: the grid."""
    data = yaml.safe_load(pathlib.Path(path).read_text())
    info = {"projector_type": data["projector_type"]}
    if info["projector_type"] == "MGRS":
        info.update(vertical_datum=data["vertical_datum"], mgrs_grid=data["mgrs_grid"])
    elif info["projector_type"] in ("LocalCartesian", "LocalCartesianUTM", "TransverseMercator"):
        info.update(vertical_datum=data["vertical_datum"],
                    latitude=float(data["map_origin"]["latitude"]),
                    longitude=float(data["map_origin"]["longitude"]), altitude=0.0)
    else:
        raise AssertionError(f"Autoware has no projector {info['projector_type']!r}")
    return info


def autoware_metadata(path):
    """pointcloud_map_metadata.yaml as pointcloud_map_loader takes it: each tile's corner as a
    pair of integers (yaml-cpp's as<std::vector<int>> refuses anything else)."""
    data = yaml.safe_load(pathlib.Path(path).read_text())
    size = (float(data.pop("x_resolution")), float(data.pop("y_resolution")))
    tiles = {}
    for name, corner in data.items():
        if len(corner) != 2 or not all(type(v) is int for v in corner):
            raise AssertionError(f"{name}: corner {corner} is not two integers")
        tiles[name] = tuple(corner)
    return size, tiles


def autoware_to_geodetic(info, points, datum):
    """Tile points (N x 3) -> lon, lat, ellipsoidal height, the way Autoware reverses its
    projectors (GeographicLib LocalCartesian at height `altitude`; UTM of the origin plus x, y;
    the MGRS square's corner plus x, y; z + altitude)."""
    kind = info["projector_type"]
    if kind == "LocalCartesian":
        lon, lat, h = enu_to_geodetic((info["latitude"], info["longitude"], info["altitude"])
                                      ).transform(points[:, 0], points[:, 1], points[:, 2])
        return np.column_stack([lon, lat, h])
    epsg = utm_epsg(datum[0], datum[1])
    to_utm_crs = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    if kind == "LocalCartesianUTM":
        e0, n0 = to_utm_crs.transform(info["longitude"], info["latitude"])
        z0 = info["altitude"]
    else:  # MGRS: the south-west corner of the datum's 100 km square
        e, n = to_utm_crs.transform(datum[1], datum[0])
        e0, n0, z0 = np.floor(e / 1e5) * 1e5, np.floor(n / 1e5) * 1e5, 0.0
    lon, lat = Transformer.from_crs(f"EPSG:{epsg}", "EPSG:4326", always_xy=True).transform(
        points[:, 0] + e0, points[:, 1] + n0)
    return np.column_stack([lon, lat, points[:, 2] + z0])


def geodetic_distance(a, b):
    """Largest distance (m) between lon, lat, h rows, by the local metres per degree."""
    lat = np.radians(a[:, 1])
    d = np.column_stack([(a[:, 0] - b[:, 0]) * 111320.0 * np.cos(lat),
                         (a[:, 1] - b[:, 1]) * 110950.0, a[:, 2] - b[:, 2]])
    return np.linalg.norm(d, axis=1).max()


def las_reader():
    """The folder with loaders.gl and the reader script, installed by scripts/test.sh
    (install_test_readers in scripts/common.sh); the test installs nothing itself."""
    folder = ROOT / "out" / "las_reader"
    if not (folder / "node_modules" / "@loaders.gl" / "las").exists():
        raise AssertionError(f"{folder}: no LAS reader installed; scripts/test.sh installs it")
    for f in ("package.json", "read_las.mjs"):
        shutil.copy(ROOT / "test" / "las" / f, folder / f)
    return folder


class Outputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = pathlib.Path(tempfile.mkdtemp(prefix="flexcloud_outputs_"))
        cls.drive = cls.tmp / "drive"
        run(BIN / "simulate_drive", "--out", cls.drive, "--map-points", "200000", "--seed", "4")
        cls.points_file = cls.tmp / "points.txt"
        slam = np.loadtxt(cls.drive / "slam_trajectory.txt")[::200, 1:4]
        np.savetxt(cls.points_file, slam, fmt="%.6f")
        cls.out = {}
        for projector in ("local_cartesian", "local_cartesian_utm", "mgrs"):
            out = cls.tmp / projector
            extra = ["--las", "--to-ll", cls.points_file] if projector == "local_cartesian" else []
            run(BIN / "georeference", "--bag", cls.drive / "drive.bag", "--map",
                cls.drive / "map.pcd", "--datum", *DATUM, "--out", out, "--autoware",
                "--projector", projector, "-q", *extra)
            cls.out[projector] = out
        cls.map = read_pcd(cls.out["local_cartesian"] / "map_georeferenced.pcd")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def tiles(self, projector):
        folder = self.out[projector] / "autoware"
        meta = yaml.safe_load((folder / "pointcloud_map_metadata.yaml").read_text())
        info = yaml.safe_load((folder / "map_projector_info.yaml").read_text())
        return folder, meta, info

    def test_every_point_is_in_exactly_one_tile_within_its_stated_bounds(self):
        folder, _, _ = self.tiles("local_cartesian")
        (size, size_y), meta = autoware_metadata(folder / "pointcloud_map_metadata.yaml")
        self.assertEqual((size, size_y), (20.0, 20.0))
        files = sorted(p.name for p in (folder / "pointcloud_map").iterdir())
        self.assertEqual(files, sorted(meta))
        parts = []
        for name, (x0, y0) in meta.items():
            t = read_pcd(folder / "pointcloud_map" / name)
            self.assertEqual(t.dtype.names, self.map.dtype.names)
            self.assertTrue(np.all((t["x"] >= x0) & (t["x"] < x0 + size)), name)
            self.assertTrue(np.all((t["y"] >= y0) & (t["y"] < y0 + size)), name)
            parts.append(t)
        tiled = np.concatenate(parts)
        self.assertEqual(len(tiled), len(self.map))
        # The same points with every field, each once: LocalCartesian keeps x and y byte for
        # byte and gives z as the ellipsoidal height (the map's ENU z plus the datum's height).
        moved = self.map.copy()
        moved["z"] = (self.map["z"].astype(np.float64) + DATUM[2]).astype(moved["z"].dtype)
        a = np.sort(moved.view(np.dtype((np.void, moved.dtype.itemsize))))
        b = np.sort(tiled.view(np.dtype((np.void, tiled.dtype.itemsize))))
        self.assertTrue(np.array_equal(a, b))
        print(f"local_cartesian: {len(meta)} tiles, {len(tiled)} points")

    def check_projector(self, projector, expected_type, to_frame):
        """Every sampled tile holds the map points pyproj puts into it, where pyproj puts them,
        and Autoware's reading of the tiles gives each point's true latitude, longitude and
        ellipsoidal height."""
        folder, _, _ = self.tiles(projector)
        info = autoware_projector_info(folder / "map_projector_info.yaml")
        self.assertEqual(info["projector_type"], expected_type)
        self.assertEqual(info["vertical_datum"], "WGS84")
        if expected_type != "MGRS":
            self.assertAlmostEqual(info["latitude"], DATUM[0], places=9)
            self.assertAlmostEqual(info["longitude"], DATUM[1], places=9)
        (size, _), meta = autoware_metadata(folder / "pointcloud_map_metadata.yaml")
        # Where each map point must go, by pyproj; tiles keep the map's order within a tile.
        enu = xyz(self.map)
        expected = to_frame(enu)
        truth = np.column_stack(enu_to_geodetic(DATUM).transform(enu[:, 0], enu[:, 1], enu[:, 2]))
        keys = np.floor(expected[:, :2] / size).astype(np.int64)
        worst = worst_geo = 0.0
        names = sorted(meta)
        for name in names[:: max(1, len(names) // 40)]:
            x0, y0 = meta[name]
            t = read_pcd(folder / "pointcloud_map" / name)
            mine = (keys[:, 0] == round(x0 / size)) & (keys[:, 1] == round(y0 / size))
            want = expected[mine]
            self.assertEqual(len(t), len(want), name)
            # float32 storage: compare with pyproj's value stored the same way.
            worst = max(worst, np.abs(xyz(t) - want.astype(np.float32).astype(np.float64)).max())
            got = autoware_to_geodetic(info, xyz(t), DATUM)
            # float32 resolves 1/2 ulp of the largest coordinate on top of the 1 mm.
            ulp = np.spacing(np.float32(np.abs(want).max()))
            self.assertLess(geodetic_distance(got, truth[mine]), 1e-3 + ulp, name)
            worst_geo = max(worst_geo, geodetic_distance(got, truth[mine]))
        self.assertLess(worst, 1e-3)
        print(f"{projector}: {len(names)} tiles, largest difference from pyproj {worst * 1e3:.3f} "
              f"mm, read back as Autoware does {worst_geo * 1e3:.3f} mm from the true place")
        return info

    def test_local_cartesian_tiles_have_the_height_autoware_reads(self):
        self.check_projector("local_cartesian", "LocalCartesian",
                             lambda enu: enu + [0.0, 0.0, DATUM[2]])

    def test_local_cartesian_utm_tiles_agree_with_pyproj(self):
        def frame(enu):
            utm = to_utm(DATUM, enu)
            origin = to_utm(DATUM, np.zeros((1, 3)))[0]
            return utm - [origin[0], origin[1], 0.0]
        self.check_projector("local_cartesian_utm", "LocalCartesianUTM", frame)

    def test_mgrs_tiles_agree_with_pyproj_inside_the_datums_square(self):
        def frame(enu):
            utm = to_utm(DATUM, enu)
            origin = to_utm(DATUM, np.zeros((1, 3)))[0]
            corner = np.floor(origin[:2] / 1e5) * 1e5
            return utm - [corner[0], corner[1], 0.0]
        info = self.check_projector("mgrs", "MGRS", frame)
        # Zone 32, latitude band U (48-56 N), then the two letters of the 100 km square.
        self.assertRegex(info["mgrs_grid"], r"^32U[A-Z]{2}$")

    def test_las_is_read_back_by_loaders_gl_with_pyproj_coordinates_and_crs(self):
        las = self.out["local_cartesian"] / "map_georeferenced.las"
        raw = las.read_bytes()
        n = len(self.map)
        rng = np.random.default_rng(1)
        idx = sorted(rng.choice(n, SAMPLE, replace=False).tolist())
        got = json.loads(run("node", las_reader() / "read_las.mjs", las, *idx).stdout)
        h = got["header"]
        self.assertEqual(h["versionAsString"], "1.4")
        self.assertIn(h["pointsFormatId"], (6, 7))
        self.assertEqual(h["pointsCount"], n)
        self.assertEqual(got["count"], n)
        self.assertEqual(h["scale"], [0.001, 0.001, 0.001])
        want = to_utm(DATUM, xyz(self.map[idx]))
        pos = np.array([p["position"] for p in got["points"]])
        err = np.abs(pos - want).max()
        self.assertLess(err, 1e-3)
        # Offsets near the data, bounds around it.
        self.assertLess(np.abs(np.array(h["offset"][:2]) - want[:, :2].mean(axis=0)).max(), 5e3)
        # The CRS: global encoding says WKT, and the WKT VLR is WGS 84 / UTM 32N for PROJ.
        self.assertTrue(struct.unpack_from("<H", raw, 6)[0] & 16)
        header_size, = struct.unpack_from("<H", raw, 94)
        vlrs, = struct.unpack_from("<I", raw, 100)
        at, wkt = header_size, None
        for _ in range(vlrs):
            user = raw[at + 2:at + 18].rstrip(b"\0").decode()
            rid, length = struct.unpack_from("<HH", raw, at + 18)
            if user == "LASF_Projection" and rid == 2112:
                wkt = raw[at + 54:at + 54 + length].rstrip(b"\0").decode()
            at += 54 + length
        self.assertIsNotNone(wkt)
        self.assertEqual(CRS.from_wkt(wkt).to_epsg(), 32632)
        print(f"LAS: {n} points, largest difference from pyproj {err * 1e3:.3f} mm, EPSG:32632")

    def test_las_keeps_intensity_rgb_and_the_other_fields(self):
        n = len(self.map)
        rng = np.random.default_rng(2)
        idx = sorted(rng.choice(n, SAMPLE, replace=False).tolist())
        # Format 6: intensity in its field, ring and label as extra bytes after the 30 bytes.
        raw = (self.out["local_cartesian"] / "map_georeferenced.las").read_bytes()
        offset, = struct.unpack_from("<I", raw, 96)
        length, = struct.unpack_from("<H", raw, 105)
        self.assertEqual(length, 30 + 2 + 4)
        records = np.frombuffer(raw, dtype=np.uint8, offset=offset).reshape(n, length)
        intensity = records[:, 12:14].copy().view("<u2").ravel()
        ring = records[:, 30:32].copy().view("<u2").ravel()
        label = records[:, 32:36].copy().view("<u4").ravel()
        self.assertTrue(np.array_equal(intensity, np.clip(np.round(self.map["intensity"]), 0, 65535)))
        self.assertTrue(np.array_equal(ring, self.map["ring"]))
        self.assertTrue(np.array_equal(label, self.map["label"]))
        # Format 7 with rgb: the drive's SLAM map with a packed rgb field instead of the others.
        src = read_pcd(self.drive / "map.pcd")
        rgb = ((np.arange(n) % 256) << 16) | (((np.arange(n) // 256) % 256) << 8) | 7
        cloud_in = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
        for a in "xyz":
            cloud_in[a] = src[a]
        cloud_in["rgb"] = rgb
        path = self.tmp / "rgb.pcd"
        header = (f"VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
                  f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n")
        path.write_bytes(header.encode() + cloud_in.tobytes())
        out = self.tmp / "rgb_out"
        run(BIN / "georeference", "--bag", self.drive / "drive.bag", "--map", path, "--datum", *DATUM,
            "--out", out, "--las", "-q")
        got = json.loads(run("node", las_reader() / "read_las.mjs", out / "map_georeferenced.las",
                             *idx).stdout)
        self.assertEqual(got["header"]["pointsFormatId"], 7)
        colours = np.array([p["color"] for p in got["points"]])
        want = np.column_stack([rgb[idx] >> 16, (rgb[idx] >> 8) & 255, rgb[idx] & 255])
        self.assertTrue(np.array_equal(colours, want), (colours[:3], want[:3]))

    def test_geojson_holds_the_trajectories_and_points_in_wgs84(self):
        g = json.loads((self.out["local_cartesian"] / "trajectories.geojson").read_text())
        self.assertEqual(g["type"], "FeatureCollection")
        lines = {f["properties"]["name"]: f["geometry"]["coordinates"] for f in g["features"]
                 if f["geometry"]["type"] == "LineString"}
        self.assertEqual(set(lines), {"gnss", "slam_aligned", "fused", "corrected"})
        corrected = np.loadtxt(self.out["local_cartesian"] / "trajectory_rubbersheet.txt")
        self.assertEqual(len(lines["corrected"]), len(corrected))
        lon, lat, h = enu_to_geodetic(DATUM).transform(*corrected[:, 1:4].T)
        got = np.array(lines["corrected"])
        self.assertLess(np.abs(got[:, 0] - lon).max(), 2e-9)
        self.assertLess(np.abs(got[:, 1] - lat).max(), 2e-9)
        self.assertLess(np.abs(got[:, 2] - h).max(), 2e-4)
        kinds = [f["properties"]["kind"] for f in g["features"]]
        self.assertEqual(kinds.count("control_point"), 200)

    def test_report_png_is_a_picture(self):
        png = (self.out["local_cartesian"] / "report.png").read_bytes()
        self.assertEqual(png[:8], b"\x89PNG\r\n\x1a\n")
        width, height = struct.unpack(">II", png[16:24])
        self.assertGreater(width, 800)
        self.assertGreater(height, 400)
        report = json.loads((self.out["local_cartesian"] / "report.json").read_text())
        self.assertTrue(report["exports"]["report_png"])

    def test_report_png_false_leaves_the_picture_out_without_a_note(self):
        out = self.tmp / "no_png"
        p = run(BIN / "georeference", "--bag", self.drive / "drive.bag", "--datum", *DATUM,
                "--out", out, "--set", "report_png=false")
        self.assertFalse((out / "report.png").exists())
        self.assertNotIn("report.png", p.stderr)
        report = json.loads((out / "report.json").read_text())
        self.assertFalse(report["exports"]["report_png"])
        self.assertTrue((out / "trajectory_rubbersheet.txt").exists())

    def test_to_ll_sends_slam_poses_where_the_corrected_trajectory_is(self):
        rows = np.loadtxt(self.out["local_cartesian"] / "points_ll.txt")
        slam = np.loadtxt(self.drive / "slam_trajectory.txt")
        corrected = np.loadtxt(self.out["local_cartesian"] / "trajectory_rubbersheet.txt")
        # The tool's prepared poses are the SLAM poses (same order here): pose i goes where the
        # corrected trajectory's pose i is.
        self.assertEqual(len(slam), len(corrected))
        lon, lat, h = enu_to_geodetic(DATUM).transform(*corrected[::200, 1:4].T)
        self.assertEqual(len(rows), len(lon))
        self.assertLess(np.abs(rows[:, 3] - lat).max(), 1e-8)  # about 1 mm
        self.assertLess(np.abs(rows[:, 4] - lon).max(), 1.5e-8)
        self.assertLess(np.abs(rows[:, 5] - h).max(), 1e-3)

    def far_map(self):
        """The drive's map with one point 10^30 m east: beyond any tile, UTM zone or LAS offset."""
        raw = bytearray((self.drive / "map.pcd").read_bytes())
        start = raw.index(b"DATA binary\n") + len(b"DATA binary\n")
        header = dict(l.split(maxsplit=1) for l in raw[:start].decode().splitlines()
                      if l and not l.startswith("#"))
        step = sum(int(s) * int(c) for s, c in zip(header["SIZE"].split(),
                                                    header["COUNT"].split()))
        raw[start + 5 * step:start + 5 * step + 4] = np.float32(1e30).tobytes()
        path = self.tmp / "far.pcd"
        path.write_bytes(bytes(raw))
        return path

    def test_bad_values_are_one_line_and_leave_no_folder(self):
        far = self.far_map()
        cases = [(["--autoware", "--tile-size", "0"], "tile_size"),
                 (["--autoware", "--tile-size", "12.5"], "give whole metres"),
                 (["--autoware", "--projector", "utm"], "projector"),
                 (["--las", "--datum", "85", "11", "0"], "80 S to 84 N"),
                 (["--map", far, "--autoware"], "far.pcd (warped): a point at"),
                 (["--map", far, "--autoware", "--projector", "mgrs"], "beyond the reach of UTM"),
                 (["--map", far, "--las"], "far.pcd (warped): a point at latitude")]
        for args, word in cases:
            out = self.tmp / "bad"
            shutil.rmtree(out, ignore_errors=True)
            p = run(BIN / "georeference", "--bag", self.drive / "drive.bag", "--map",
                    self.drive / "map.pcd", "--out", out, "-q", *args, check=False)
            self.assertIn(p.returncode, (1, 2), args)
            lines = [l for l in p.stderr.splitlines() if l.strip()]
            self.assertEqual(len(lines), 1, p.stderr)
            self.assertIn(word, lines[0])
            self.assertFalse(out.exists(), args)


if __name__ == "__main__":
    unittest.main()
