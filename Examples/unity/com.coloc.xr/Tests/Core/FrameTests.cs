// The scan <-> Unity change of frame: exact round trips, the handedness flip, the sign of a
// yaw, consistency with composition, and known poses of the twin.
using System;
using System.IO;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class FrameTests
    {
        const double Deg = Math.PI / 180.0;

        static Pose RandomPose(Random r)
        {
            var q = new Quat(r.NextDouble() - 0.5, r.NextDouble() - 0.5, r.NextDouble() - 0.5, r.NextDouble() - 0.5).Normalized;
            return new Pose(new Vec3(20 * r.NextDouble() - 10, 20 * r.NextDouble() - 10, 5 * r.NextDouble()), q);
        }

        static void Near(Vec3 a, Vec3 b, double tol, string what)
        {
            Assert.That((a - b).Norm, Is.LessThanOrEqualTo(tol), what + ": " + a + " vs " + b);
        }

        [Test]
        public void PositionsSwapYAndZ()
        {
            Assert.AreEqual(new Vec3(1, 3, 2), Frames.ScanToUnity(new Vec3(1, 2, 3)));
            Assert.AreEqual(new Vec3(1, 3, 2), Frames.UnityToScan(new Vec3(1, 2, 3)));
            // Up is up: 1.7 m above the scan's floor is 1.7 m on Unity's y.
            Assert.AreEqual(1.7, Frames.ScanToUnity(new Vec3(4, -2, 1.7)).Y);
        }

        [Test]
        public void RoundTripsAreBitExact()
        {
            var r = new Random(36);
            for (int i = 0; i < 1000; ++i)
            {
                Pose p = RandomPose(r);
                Assert.AreEqual(p, Frames.UnityToScan(Frames.ScanToUnity(p)));
                Assert.AreEqual(p, Frames.ScanToUnity(Frames.UnityToScan(p)));
            }
        }

        [Test]
        public void HandednessFlips()
        {
            Vec3 x = Frames.ScanToUnity(new Vec3(1, 0, 0));
            Vec3 y = Frames.ScanToUnity(new Vec3(0, 1, 0));
            Vec3 z = Frames.ScanToUnity(new Vec3(0, 0, 1));
            // The scan's right-handed triad x, y, z = x cross y lands on Unity's x, z, y, for which
            // the same cross-product formula gives -up: a left-handed triad.
            Assert.AreEqual(new Vec3(1, 0, 0), x);
            Assert.AreEqual(new Vec3(0, 0, 1), y);
            Assert.AreEqual(new Vec3(0, 1, 0), z);
            Assert.AreEqual(-z, Vec3.Cross(x, y));
            // Determinant of the map = x . (y cross z) = -1: a reflection, no scale.
            Assert.AreEqual(-1.0, Vec3.Dot(x, Vec3.Cross(y, z)));
        }

        [Test]
        public void YawAboutScanZIsMinusYawAboutUnityY()
        {
            foreach (double degrees in new[] { 30.0, 90.0, -45.0, 170.0 })
            {
                Quat scan = Quat.AxisAngle(new Vec3(0, 0, 1), degrees * Deg);
                Quat unity = Frames.ScanToUnity(scan);
                Quat expected = Quat.AxisAngle(new Vec3(0, 1, 0), -degrees * Deg); // Quaternion.Euler(0, -degrees, 0)
                Assert.That(Quat.AngleBetween(unity, expected), Is.LessThan(1e-15), degrees + " deg");
                // Both turn east toward north (counter-clockwise from above): scan x -> y is Unity x -> z.
                Vec3 east = new Vec3(1, 0, 0);
                Near(Frames.ScanToUnity(scan.Rotate(east)), unity.Rotate(Frames.ScanToUnity(east)), 1e-15, "rotated east");
            }
            Vec3 turned = Frames.ScanToUnity(Quat.AxisAngle(new Vec3(0, 0, 1), 90 * Deg)).Rotate(new Vec3(1, 0, 0));
            Near(turned, new Vec3(0, 0, 1), 1e-15, "+90 deg in the scan turns Unity's x to Unity's z");
        }

        [Test]
        public void ConversionCommutesWithPosesAndPoints()
        {
            var r = new Random(7);
            for (int i = 0; i < 1000; ++i)
            {
                Pose a = RandomPose(r), b = RandomPose(r);
                var p = new Vec3(r.NextDouble(), r.NextDouble(), r.NextDouble());
                Pose ab = Frames.ScanToUnity(a * b), aUbU = Frames.ScanToUnity(a) * Frames.ScanToUnity(b);
                Near(ab.Position, aUbU.Position, 1e-12, "composition");
                Assert.That(Quat.AngleBetween(ab.Rotation, aUbU.Rotation), Is.LessThan(1e-7));
                Near(Frames.ScanToUnity(a.Inverse).Position, Frames.ScanToUnity(a).Inverse.Position, 1e-12, "inverse");
                Near(Frames.ScanToUnity(a.Transform(p)), Frames.ScanToUnity(a).Transform(Frames.ScanToUnity(p)), 1e-12, "point");
            }
        }

        // The twin's headset frame starts yawed about the scan's z (calibration.yaml,
        // world_from_xr_start): in Unity that is a pure rotation about y, of the opposite sign.
        [Test]
        public void KnownPosesFromTheTwin()
        {
            string twin = TestEnvironment.Twin;
            double[] m = HandEyeCalibration.Matrix(File.ReadAllText(Path.Combine(twin, "headset", "calibration.yaml")),
                                                   "world_from_xr_start", "calibration.yaml");
            Pose worldFromXr = Pose.FromMatrix(m);
            double yaw = Math.Atan2(m[4], m[0]);
            Pose unity = Frames.ScanToUnity(worldFromXr);
            Assert.That(Quat.AngleBetween(unity.Rotation, Quat.AxisAngle(new Vec3(0, 1, 0), -yaw)), Is.LessThan(1e-6));
            Assert.AreEqual(worldFromXr.Position.Z, unity.Position.Y); // height stays height
            TestEnvironment.Report($"twin world_from_xr_start: yaw {yaw / Deg:F2} deg about the scan's z = {-yaw / Deg:F2} deg about Unity's y");

            // The head's height above the scan floor is Unity's y, pose by pose, and its view
            // direction converts like a position.
            var truth = TestEnvironment.ReadTum(Path.Combine(twin, "headset", "headset_groundtruth.txt"));
            foreach (var s in truth)
            {
                Pose u = Frames.ScanToUnity(s.Pose);
                Assert.AreEqual(s.Pose.Position.Z, u.Position.Y);
                Assert.That(u.Position.Y, Is.InRange(1.0, 2.2), "head height in Unity");
                Vec3 forward = s.Pose.Rotation.Rotate(new Vec3(0, 0, 1));
                Near(Frames.ScanToUnity(forward), u.Rotation.Rotate(Frames.ScanToUnity(new Vec3(0, 0, 1))), 1e-12, "view direction");
            }
        }
    }
}
