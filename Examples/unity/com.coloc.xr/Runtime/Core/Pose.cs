// Double-precision vector, quaternion and rigid pose, free of UnityEngine so that the core
// assembly builds and is tested outside Unity (mono). Poses are "a_from_b": they map points of
// frame b into frame a, as everywhere in coloc.
using System;
using System.Globalization;

namespace Coloc
{
    public struct Vec3 : IEquatable<Vec3>
    {
        public readonly double X, Y, Z;

        public Vec3(double x, double y, double z) { X = x; Y = y; Z = z; }

        public static readonly Vec3 Zero = new Vec3(0, 0, 0);

        public static Vec3 operator +(Vec3 a, Vec3 b) => new Vec3(a.X + b.X, a.Y + b.Y, a.Z + b.Z);
        public static Vec3 operator -(Vec3 a, Vec3 b) => new Vec3(a.X - b.X, a.Y - b.Y, a.Z - b.Z);
        public static Vec3 operator -(Vec3 a) => new Vec3(-a.X, -a.Y, -a.Z);
        public static Vec3 operator *(double s, Vec3 a) => new Vec3(s * a.X, s * a.Y, s * a.Z);

        public static double Dot(Vec3 a, Vec3 b) => a.X * b.X + a.Y * b.Y + a.Z * b.Z;

        // The same formula in both frames; which handedness it means is the frame's business (the
        // handedness tests rely on exactly that).
        public static Vec3 Cross(Vec3 a, Vec3 b) =>
            new Vec3(a.Y * b.Z - a.Z * b.Y, a.Z * b.X - a.X * b.Z, a.X * b.Y - a.Y * b.X);

        public double Norm => Math.Sqrt(Dot(this, this));

        public bool AllFinite => !double.IsNaN(X + Y + Z) && !double.IsInfinity(X + Y + Z);

        public bool Equals(Vec3 o) => X == o.X && Y == o.Y && Z == o.Z;
        public override bool Equals(object o) => o is Vec3 v && Equals(v);
        public override int GetHashCode() => X.GetHashCode() ^ (Y.GetHashCode() << 1) ^ (Z.GetHashCode() << 2);

        public override string ToString() =>
            string.Format(CultureInfo.InvariantCulture, "({0:R}, {1:R}, {2:R})", X, Y, Z);
    }

    // Hamilton quaternion x, y, z, w (the order of coloc's files, C ABI and OSC messages).
    public struct Quat : IEquatable<Quat>
    {
        public readonly double X, Y, Z, W;

        public Quat(double x, double y, double z, double w) { X = x; Y = y; Z = z; W = w; }

        public static readonly Quat Identity = new Quat(0, 0, 0, 1);

        // Right-handed sense in a right-handed frame (the scan's): counter-clockwise seen from the
        // tip of the axis. Unity's Quaternion.AngleAxis means the same numbers, which its
        // left-handed frame shows clockwise.
        public static Quat AxisAngle(Vec3 axis, double radians)
        {
            double n = axis.Norm;
            double s = Math.Sin(radians / 2) / n;
            return new Quat(axis.X * s, axis.Y * s, axis.Z * s, Math.Cos(radians / 2));
        }

        public static Quat operator *(Quat a, Quat b) => new Quat(
            a.W * b.X + a.X * b.W + a.Y * b.Z - a.Z * b.Y,
            a.W * b.Y - a.X * b.Z + a.Y * b.W + a.Z * b.X,
            a.W * b.Z + a.X * b.Y - a.Y * b.X + a.Z * b.W,
            a.W * b.W - a.X * b.X - a.Y * b.Y - a.Z * b.Z);

        public Quat Conjugate => new Quat(-X, -Y, -Z, W);
        public double Norm => Math.Sqrt(X * X + Y * Y + Z * Z + W * W);

        public Quat Normalized
        {
            get { double n = Norm; return new Quat(X / n, Y / n, Z / n, W / n); }
        }

        // v' = v + 2w (u x v) + 2 u x (u x v), u = (x, y, z): the standard rotation, the same as
        // Unity's Quaternion * Vector3 and Eigen's.
        public Vec3 Rotate(Vec3 v)
        {
            var u = new Vec3(X, Y, Z);
            Vec3 t = 2.0 * Vec3.Cross(u, v);
            return v + W * t + Vec3.Cross(u, t);
        }

        // Angle of the rotation between two unit quaternions (q and -q are the same rotation).
        // atan2 of the relative rotation's parts, not acos of a dot product: exact near zero.
        public static double AngleBetween(Quat a, Quat b)
        {
            Quat d = a.Conjugate * b;
            double v = Math.Sqrt(d.X * d.X + d.Y * d.Y + d.Z * d.Z);
            return 2.0 * Math.Atan2(v, Math.Abs(d.W));
        }

        // From a proper rotation matrix (row-major 3x3 inside a 4x4 here), Shepperd's method.
        public static Quat FromMatrix(double[,] m)
        {
            double trace = m[0, 0] + m[1, 1] + m[2, 2];
            double x, y, z, w;
            if (trace > 0)
            {
                double s = Math.Sqrt(trace + 1.0) * 2;
                w = 0.25 * s; x = (m[2, 1] - m[1, 2]) / s; y = (m[0, 2] - m[2, 0]) / s; z = (m[1, 0] - m[0, 1]) / s;
            }
            else if (m[0, 0] > m[1, 1] && m[0, 0] > m[2, 2])
            {
                double s = Math.Sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2;
                w = (m[2, 1] - m[1, 2]) / s; x = 0.25 * s; y = (m[0, 1] + m[1, 0]) / s; z = (m[0, 2] + m[2, 0]) / s;
            }
            else if (m[1, 1] > m[2, 2])
            {
                double s = Math.Sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2;
                w = (m[0, 2] - m[2, 0]) / s; x = (m[0, 1] + m[1, 0]) / s; y = 0.25 * s; z = (m[1, 2] + m[2, 1]) / s;
            }
            else
            {
                double s = Math.Sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2;
                w = (m[1, 0] - m[0, 1]) / s; x = (m[0, 2] + m[2, 0]) / s; y = (m[1, 2] + m[2, 1]) / s; z = 0.25 * s;
            }
            return new Quat(x, y, z, w).Normalized;
        }

        public bool Equals(Quat o) => X == o.X && Y == o.Y && Z == o.Z && W == o.W;
        public override bool Equals(object o) => o is Quat q && Equals(q);
        public override int GetHashCode() => X.GetHashCode() ^ (Y.GetHashCode() << 1) ^ (Z.GetHashCode() << 2) ^ (W.GetHashCode() << 3);

        public override string ToString() =>
            string.Format(CultureInfo.InvariantCulture, "({0:R}, {1:R}, {2:R}, {3:R})", X, Y, Z, W);
    }

    // A rigid transform a_from_b: p_a = Rotation * p_b + Position.
    public struct Pose : IEquatable<Pose>
    {
        public readonly Vec3 Position;
        public readonly Quat Rotation;

        public Pose(Vec3 position, Quat rotation) { Position = position; Rotation = rotation; }

        public static readonly Pose Identity = new Pose(Vec3.Zero, Quat.Identity);

        // a_from_b * b_from_c = a_from_c.
        public static Pose operator *(Pose a, Pose b) =>
            new Pose(a.Position + a.Rotation.Rotate(b.Position), a.Rotation * b.Rotation);

        public Pose Inverse
        {
            get { Quat q = Rotation.Conjugate; return new Pose(-q.Rotate(Position), q); }
        }

        public Vec3 Transform(Vec3 p) => Position + Rotation.Rotate(p);

        // 4x4 row-major [R t; 0 1], as `coloc handeye` and OpenCV YAML files store poses.
        public static Pose FromMatrix(double[] rowMajor16)
        {
            if (rowMajor16 == null || rowMajor16.Length != 16)
                throw new ArgumentException("a pose matrix needs 16 numbers (4x4 row-major)");
            var r = new double[3, 3];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) r[i, j] = rowMajor16[4 * i + j];
            return new Pose(new Vec3(rowMajor16[3], rowMajor16[7], rowMajor16[11]), Quat.FromMatrix(r));
        }

        public bool Equals(Pose o) => Position.Equals(o.Position) && Rotation.Equals(o.Rotation);
        public override bool Equals(object o) => o is Pose p && Equals(p);
        public override int GetHashCode() => Position.GetHashCode() ^ Rotation.GetHashCode();
        public override string ToString() => "p " + Position + " q " + Rotation;
    }
}
