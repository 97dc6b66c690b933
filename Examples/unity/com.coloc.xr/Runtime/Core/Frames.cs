// The change of frame between coloc's scan frame and Unity's world, the one place where
// co-location breaks silently: a mirrored axis looks almost right near the origin.
//
//   scan (coloc)                      Unity
//   right-handed, z up, metres        left-handed, y up, metres
//   x                        ->       x
//   y                        ->       z
//   z (up)                   ->       y (up)
//
// Positions: unity = (x, z, y) of the scan, and back the same way. The swap of two axes is a
// reflection (determinant -1): it is exactly what turns a right-handed frame into a
// left-handed one, with no scale and no offset.
//
// Rotations: R_unity = P R_scan P with P the swap. For a quaternion (x, y, z, w) this is
// (-x, -z, -y, w): the axis is swapped like a position and, the frame's handedness being
// flipped, the sense of rotation with it. A rotation of +a about the scan's z (counter-clockwise
// seen from above) is a rotation of -a about Unity's y: Quaternion.Euler(0, -a, 0), which
// Unity's left-handed frame shows counter-clockwise seen from above too: the same motion.
//
// Poses a_from_b convert on both sides (world and body axes): T_unity = P T_scan P. So
// conversion commutes with composition and inversion, and a pose that entered coloc from Unity
// (a headset's xr_from_head) comes back bit for bit: every operation is a swap or a negation,
// exact in floating point.
namespace Coloc
{
    public static class Frames
    {
        public static Vec3 ScanToUnity(Vec3 p) => new Vec3(p.X, p.Z, p.Y);
        public static Vec3 UnityToScan(Vec3 p) => new Vec3(p.X, p.Z, p.Y);

        public static Quat ScanToUnity(Quat q) => new Quat(-q.X, -q.Z, -q.Y, q.W);
        public static Quat UnityToScan(Quat q) => new Quat(-q.X, -q.Z, -q.Y, q.W);

        public static Pose ScanToUnity(Pose p) => new Pose(ScanToUnity(p.Position), ScanToUnity(p.Rotation));
        public static Pose UnityToScan(Pose p) => new Pose(UnityToScan(p.Position), UnityToScan(p.Rotation));
    }
}
