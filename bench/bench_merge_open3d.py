#!/usr/bin/python3
"""Open3D's ScalableTSDFVolume on RGB-D frames, for bench_merge: the same frames, voxel size and
truncation as pg-merge. Prints one JSON line: integration ms per frame, extraction seconds, peak
resident memory, and writes the mesh. Needs Debian's python3-open3d (run with /usr/bin/python3)."""
import argparse
import json
import time

import numpy as np
import open3d as o3d


def read_depth(path):
    """16-bit PGM (big-endian, as the Kinect frames) or PNG, as uint16."""
    if path.endswith(".pgm"):
        with open(path, "rb") as f:
            data = f.read()
        fields, pos = [], 0
        while len(fields) < 4:  # magic, width, height, maxval (no comments in these files)
            while data[pos : pos + 1].isspace():
                pos += 1
            end = pos
            while not data[end : end + 1].isspace():
                end += 1
            fields.append(data[pos:end])
            pos = end
        width, height = int(fields[1]), int(fields[2])
        pixels = np.frombuffer(data[pos + 1 : pos + 1 + width * height * 2], dtype=">u2")
        return pixels.reshape(height, width).astype(np.uint16)
    return np.asarray(o3d.io.read_image(path)).astype(np.uint16)


def peak_resident_bytes():
    """VmHWM: unlike getrusage's maxrss, not inherited from the parent process."""
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return 0


def pose_matrices(path):
    poses = []
    for line in open(path):
        values = line.split("#")[0].split()
        if len(values) != 7:
            continue
        tx, ty, tz, qx, qy, qz, qw = map(float, values)
        world_from_cam = np.eye(4)
        world_from_cam[:3, :3] = o3d.geometry.get_rotation_matrix_from_quaternion([qw, qx, qy, qz])
        world_from_cam[:3, 3] = [tx, ty, tz]
        poses.append(np.linalg.inv(world_from_cam))  # Open3D wants the extrinsic (world to camera)
    return poses


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--poses", required=True)
    p.add_argument("--intrinsics", type=float, nargs=4, required=True)
    p.add_argument("--size", type=int, nargs=2, default=[640, 480])
    p.add_argument("--depth", required=True, help="pattern with {id}, ids 1..N in pose order")
    p.add_argument("--color", default="")
    p.add_argument("--depth-scale", type=float, default=1000.0, help="depth units per metre")
    p.add_argument("--max-depth", type=float, default=3.0)
    p.add_argument("--voxel", type=float, required=True)
    p.add_argument("--truncation", type=float, required=True)
    p.add_argument("--out", required=True)
    a = p.parse_args()

    fx, fy, cx, cy = a.intrinsics
    intrinsic = o3d.camera.PinholeCameraIntrinsic(a.size[0], a.size[1], fx, fy, cx, cy)
    color_type = o3d.pipelines.integration.TSDFVolumeColorType.RGB8 if a.color else o3d.pipelines.integration.TSDFVolumeColorType.NoColor
    volume = o3d.pipelines.integration.ScalableTSDFVolume(voxel_length=a.voxel, sdf_trunc=a.truncation, color_type=color_type)
    # One frame at a time, as pg-merge reads its inputs: read (not timed), integrate (timed), drop.
    integrate_seconds = 0.0
    frames = 0
    for i, extrinsic in enumerate(pose_matrices(a.poses)):
        frame_id = str(i + 1)
        depth = o3d.geometry.Image(read_depth(a.depth.replace("{id}", frame_id)))
        if a.color:
            color = o3d.io.read_image(a.color.replace("{id}", frame_id))
        else:
            color = o3d.geometry.Image(np.zeros((a.size[1], a.size[0], 3), dtype=np.uint8))
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth, depth_scale=a.depth_scale, depth_trunc=a.max_depth, convert_rgb_to_intensity=False)
        start = time.perf_counter()
        volume.integrate(rgbd, intrinsic, extrinsic)
        integrate_seconds += time.perf_counter() - start
        frames += 1
        del rgbd, depth, color
    start = time.perf_counter()
    mesh = volume.extract_triangle_mesh()
    extract_seconds = time.perf_counter() - start
    o3d.io.write_triangle_mesh(a.out, mesh)
    print(json.dumps({
        "integrate_ms_per_frame": 1000 * integrate_seconds / frames,
        "extract_seconds": extract_seconds,
        "peak_bytes": peak_resident_bytes(),
        "vertices": len(mesh.vertices),
        "faces": len(mesh.triangles),
    }))


if __name__ == "__main__":
    main()
