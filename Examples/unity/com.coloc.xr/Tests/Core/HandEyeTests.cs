// The calibration readers and composition helpers against what `coloc handeye` writes and
// computes, and the in-process localizer on the registered twin map.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Linq;
using System.Text.RegularExpressions;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class HandEyeTests
    {
        static double[] JsonMatrix(string json, string key)
        {
            Match m = Regex.Match(json, "\"" + key + "\"\\s*:\\s*\\[(.*?\\]\\s*)\\]", RegexOptions.Singleline);
            Assert.IsTrue(m.Success, key + " in " + json);
            double[] v = Regex.Matches(m.Groups[1].Value, @"-?\d+(\.\d+)?([eE][-+]?\d+)?")
                .Cast<Match>().Select(x => double.Parse(x.Value, CultureInfo.InvariantCulture)).ToArray();
            Assert.AreEqual(16, v.Length);
            return v;
        }

        static void SamePose(Pose a, Pose b, double tol, string what)
        {
            Assert.That((a.Position - b.Position).Norm, Is.LessThan(tol), what + " position");
            Assert.That(Quat.AngleBetween(a.Rotation, b.Rotation), Is.LessThan(tol), what + " rotation");
        }

        [Test]
        public void LinkAndPerRegistrationMatchColocHandeye()
        {
            string coloc = TestEnvironment.Coloc;
            string dir = TestEnvironment.ScratchDir("handeye");
            var sim = TestEnvironment.Run(coloc, $"handeye simulate --out \"{dir}\" --seed 3");
            Assert.AreEqual(0, sim.ExitCode, sim.Stderr);
            string solved = Path.Combine(dir, "solved.yaml"), truth = Path.Combine(dir, "truth.yaml");
            var solve = TestEnvironment.Run(coloc, $"handeye solve --pairs \"{Path.Combine(dir, "pairs.csv")}\" --output \"{solved}\"");
            Assert.AreEqual(0, solve.ExitCode, solve.Stderr);
            HandEyeCalibration a = HandEyeCalibration.Read(solved), b = HandEyeCalibration.Read(truth);

            // `coloc handeye link A B`: the same transform between the two VR systems.
            var link = TestEnvironment.Run(coloc, $"handeye link \"{solved}\" \"{truth}\" --json");
            Assert.AreEqual(0, link.ExitCode, link.Stderr);
            Pose cli = Pose.FromMatrix(JsonMatrix(link.Stdout, "vr_b_from_vr_a"));
            Pose ours = Compose.VrBFromVrA(a.VrFromCamera, b.VrFromCamera);
            SamePose(ours, cli, 1e-8, "vr_b_from_vr_a");
            TestEnvironment.Report($"handeye link: C# vs coloc {(ours.Position - cli.Position).Norm:E1} m, {Quat.AngleBetween(ours.Rotation, cli.Rotation):E1} rad");

            // Each registration composed with the solved device_from_marker lands near the solved
            // vr_from_camera (the paper's M_c2v; their spread is the measurement noise).
            int n = 0;
            foreach (string line in File.ReadAllLines(Path.Combine(dir, "pairs.csv")))
            {
                if (line.StartsWith("#", StringComparison.Ordinal) || line.Trim().Length == 0) continue;
                double[] f = line.Split(new[] { ',', ' ' }, StringSplitOptions.RemoveEmptyEntries)
                    .Select(x => double.Parse(x, CultureInfo.InvariantCulture)).ToArray();
                var device = new Pose(new Vec3(f[1], f[2], f[3]), new Quat(f[4], f[5], f[6], f[7]).Normalized);
                var marker = new Pose(new Vec3(f[8], f[9], f[10]), new Quat(f[11], f[12], f[13], f[14]).Normalized);
                SamePose(Compose.VrFromCamera(device, a.DeviceFromMarker, marker, a.Sigma), a.VrFromCamera, 0.05, "registration " + n);
                ++n;
            }
            Assert.That(n, Is.GreaterThan(3));
        }

        [Test]
        public void HeadsetMountingAndComposition()
        {
            string path = Path.Combine(TestEnvironment.Twin, "headset", "calibration.yaml");
            Pose camFromHead = HandEyeCalibration.ReadCamFromHead(path);
            // The twin's camera sits 9 cm below and 6 cm behind... whatever the file says: its numbers.
            double[] m = HandEyeCalibration.Matrix(File.ReadAllText(path), "cam_from_headset", path);
            Assert.AreEqual(m[3], camFromHead.Position.X);
            Assert.AreEqual(m[7], camFromHead.Position.Y);
            Assert.AreEqual(m[11], camFromHead.Position.Z);
            // world_from_head = world_from_cam * cam_from_head, and the controller helpers invert.
            var worldFromCam = new Pose(new Vec3(1, 2, 1.6), Quat.AxisAngle(new Vec3(0.2, 0.1, 1), 0.7));
            Pose worldFromHead = Compose.WorldFromHead(worldFromCam, camFromHead);
            SamePose(worldFromHead * camFromHead.Inverse, worldFromCam, 1e-12, "mounting");
            var vrFromHead = new Pose(new Vec3(0.1, 1.7, 0.2), Quat.AxisAngle(new Vec3(0, 1, 0), 0.3));
            var vrFromController = new Pose(new Vec3(0.3, 1.2, 0.5), Quat.AxisAngle(new Vec3(1, 0, 0), -0.4));
            Pose headFromController = Compose.HeadFromController(vrFromHead, vrFromController);
            SamePose(vrFromHead * headFromController, vrFromController, 1e-12, "controller");
            Pose worldFromVr = worldFromHead * vrFromHead.Inverse;
            SamePose(Compose.WorldFromController(worldFromHead, headFromController), worldFromVr * vrFromController, 1e-12, "controller in the scan");
            Assert.Throws<ColocException>(() => HandEyeCalibration.Read(path)); // not a hand-eye file: named
        }

        [Test]
        public void LocalizerOpensTheRegisteredMap()
        {
            TestEnvironment.RequireLibraries();
            string vocabulary = TestEnvironment.Require("COLOC_VOCABULARY");
            using (var localizer = new Localizer(Path.Combine(TestEnvironment.Fixture, "site.db"), vocabulary))
            {
                Assert.AreEqual("scan", localizer.FrameName);
                Assert.That(localizer.Keyframes, Is.GreaterThan(0UL));
                Assert.That(localizer.Points, Is.GreaterThan(100UL));
                // A blank frame localizes nowhere: LOST, not an exception.
                int w = 640, h = 480;
                LocalizeResult r = localizer.Localize(new byte[w * h * 3], w, h, 3, new float[w * h], 1000.0);
                Assert.AreEqual(TrackingState.Lost, r.State);
                var e = Assert.Throws<ColocException>(() => localizer.Localize(new byte[w * h * 3], w, h, 3, null, double.NaN));
                StringAssert.Contains("COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT", e.Message);
                // The scan anchor: a NaN point is named, and the handle goes on.
                e = Assert.Throws<ColocException>(() => localizer.AnchorToScan(new float[] { 0f, 0f, float.NaN }));
                StringAssert.Contains("point 0 is not finite", e.Message);
                localizer.AnchorToScan(null);
                TestEnvironment.Report($"in-process localizer: map '{localizer.FrameName}', {localizer.Keyframes} keyframes, {localizer.Points} points");
            }
        }
    }
}
