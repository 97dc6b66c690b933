// Drift fusion through P/Invoke against `coloc fuse` on the same recorded inputs, and the Unity
// frame API against the scan frame one.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Linq;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class FusionTests
    {
        // Global poses: the twin's true head at 30 Hz (every third headset stamp) with a few
        // millimetres of deterministic noise, written as text so both sides read the same numbers.
        static string WriteGlobal(string dir, List<TestEnvironment.Stamped> truth)
        {
            var r = new Random(1);
            var lines = new List<string> { "# timestamp tx ty tz qx qy qz qw (world_from_head)" };
            for (int i = 0; i < truth.Count; i += 3)
            {
                Pose t = truth[i].Pose;
                var noisy = new Pose(t.Position + new Vec3(0.004 * (r.NextDouble() - 0.5), 0.004 * (r.NextDouble() - 0.5), 0.004 * (r.NextDouble() - 0.5)),
                                     (t.Rotation * Quat.AxisAngle(new Vec3(r.NextDouble(), r.NextDouble(), 1), 0.002)).Normalized);
                lines.Add(TestEnvironment.TumLine(truth[i].Time, noisy));
            }
            string path = Path.Combine(dir, "global.txt");
            File.WriteAllLines(path, lines);
            return path;
        }

        [Test]
        public void SameFusedPosesAsColocFuse()
        {
            TestEnvironment.RequireLibraries();
            string dir = TestEnvironment.ScratchDir("fuse");
            string xrPath = Path.Combine(TestEnvironment.Twin, "headset", "headset.txt");
            var xr = TestEnvironment.ReadTum(xrPath);
            var truth = TestEnvironment.ReadTum(Path.Combine(TestEnvironment.Twin, "headset", "headset_groundtruth.txt"));
            var global = TestEnvironment.ReadTum(WriteGlobal(dir, truth));
            string outPath = Path.Combine(dir, "fused.txt");
            var run = TestEnvironment.Run(TestEnvironment.Coloc,
                $"fuse --xr \"{xrPath}\" --global \"{Path.Combine(dir, "global.txt")}\" --out \"{outPath}\" --json");
            Assert.AreEqual(0, run.ExitCode, run.Stderr);
            var cli = TestEnvironment.ReadTum(outPath);

            // The replay of `coloc fuse` (fusion/replay.cpp): before each headset pose, every global
            // pose stamped at or before it (no latency).
            var ours = new List<FusedPose>();
            using (var fusion = new DriftFusion())
            {
                int next = 0;
                foreach (var h in xr)
                {
                    for (; next < global.Count && global[next].Time <= h.Time; ++next)
                        fusion.PushGlobalPose(global[next].Time, global[next].Pose);
                    ours.Add(fusion.PushXrPose(h.Time, h.Pose));
                }
                FusionStats stats = fusion.Stats;
                Assert.AreEqual((ulong)xr.Count, stats.XrPoses);
                Assert.AreEqual((ulong)global.Count, stats.GlobalPoses);
                Assert.AreEqual(FusionState.Tracking, stats.State);
            }
            Assert.AreEqual(cli.Count, ours.Count, "one fused pose per headset pose on both sides");
            double maxPosition = 0, maxAngle = 0;
            for (int i = 0; i < cli.Count; ++i)
            {
                Assert.AreEqual(cli[i].Time, ours[i].Time, 1e-6);
                maxPosition = Math.Max(maxPosition, (cli[i].Pose.Position - ours[i].WorldFromHead.Position).Norm);
                maxAngle = Math.Max(maxAngle, Quat.AngleBetween(cli[i].Pose.Rotation.Normalized, ours[i].WorldFromHead.Rotation));
            }
            TestEnvironment.Report($"P/Invoke vs coloc fuse: {cli.Count} fused poses, max difference {maxPosition:E2} m, {maxAngle:E2} rad");
            // `coloc fuse` writes 9 decimals: the rest is the text, not the fusion.
            Assert.That(maxPosition, Is.LessThan(1e-8));
            Assert.That(maxAngle, Is.LessThan(1e-7));
        }

        [Test]
        public void DefaultsMirrorTheLibrarys()
        {
            TestEnvironment.RequireLibraries();
            FusionOptions lib = FusionOptions.FromLibrary(), ours = new FusionOptions();
            Assert.AreEqual(lib.ProcessNoise, ours.ProcessNoise);
            Assert.AreEqual(lib.MeasurementNoise, ours.MeasurementNoise);
            Assert.AreEqual(lib.TranslationSigma, ours.TranslationSigma);
            Assert.AreEqual(lib.RotationSigma, ours.RotationSigma);
            Assert.AreEqual(lib.Gating, ours.Gating);
            Assert.AreEqual(lib.GateChi2, ours.GateChi2);
            Assert.AreEqual(lib.TimeAlignment, ours.TimeAlignment);
            Assert.AreEqual(lib.HoldAfter, ours.HoldAfter);
            Assert.AreEqual(lib.MaxCorrectionSpeed, ours.MaxCorrectionSpeed);
            Assert.AreEqual(lib.MaxCorrectionRate, ours.MaxCorrectionRate);
        }

        [Test]
        public void UnityFrameApiIsTheScanApiConverted()
        {
            TestEnvironment.RequireLibraries();
            var xr = TestEnvironment.ReadTum(Path.Combine(TestEnvironment.Twin, "headset", "headset.txt"));
            var truth = TestEnvironment.ReadTum(Path.Combine(TestEnvironment.Twin, "headset", "headset_groundtruth.txt"));
            using (var scan = new DriftFusion())
            using (var unity = new DriftFusion())
            {
                for (int i = 0; i < 300; ++i)
                {
                    if (i % 3 == 0)
                    {
                        scan.PushGlobalPose(truth[i].Time, truth[i].Pose);
                        unity.PushGlobalPose(truth[i].Time, truth[i].Pose);
                    }
                    FusedPose a = scan.PushXrPose(xr[i].Time, xr[i].Pose);
                    FusedPose b = unity.PushUnityXrPose(xr[i].Time, Frames.ScanToUnity(xr[i].Pose));
                    Assert.AreEqual(Frames.ScanToUnity(a.WorldFromHead), b.WorldFromHead, "bit for bit");
                    Assert.AreEqual(a.State, b.State);
                }
                Assert.AreEqual(FusionState.Tracking, unity.Latest.State);
            }
        }
    }
}
