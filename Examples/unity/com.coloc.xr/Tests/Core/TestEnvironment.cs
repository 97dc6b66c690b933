// Where the tests find what they run against. Outside Unity, tests/unity/run_unity_tests.sh sets
// these; inside Unity's Test Runner they are unset and the tests needing them are ignored (the
// pure ones, frame conversion and OSC layout, run everywhere).
//   COLOC_BIN                the coloc command-line tool of the same build
//   COLOC_UNITY_FIXTURE      a twin room (twin/), its map registered to the scan (site.db)
//   COLOC_VOCABULARY         the vocabulary the map was built with
//   COLOC_UNITY_PROBE        MissingLibraryProbe.exe (the missing-library check, in a child)
//   LD_LIBRARY_PATH          where libcoloc_fusion_c.so and libcoloc_localize_c.so are
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.Globalization;
using System.IO;
using System.Net;
using System.Net.Sockets;
using System.Text;
using NUnit.Framework;

namespace Coloc.Tests
{
    public static class TestEnvironment
    {
        public static string Require(string variable)
        {
            string v = Environment.GetEnvironmentVariable(variable);
            if (string.IsNullOrEmpty(v)) Assert.Ignore(variable + " is not set (run through tests/unity/run_unity_tests.sh)");
            return v;
        }

        public static string Coloc => Require("COLOC_BIN");
        public static string Fixture => Require("COLOC_UNITY_FIXTURE");
        public static string Twin => Path.Combine(Fixture, "twin");

        // The native libraries must load here; a missing one fails the test with the package's
        // message (the missing-library behaviour itself is checked in a child process).
        public static void RequireLibraries()
        {
            Require("COLOC_BIN");
            ColocLibrary.EnsureFusion();
        }

        public static string ScratchDir(string name)
        {
            string dir = Path.Combine(Path.GetTempPath(), "coloc_unity_" + name + "_" + Process.GetCurrentProcess().Id);
            if (Directory.Exists(dir)) Directory.Delete(dir, true);
            Directory.CreateDirectory(dir);
            return dir;
        }

        public struct RunResult { public int ExitCode; public string Stdout, Stderr; }

        // Runs a program to its end (no wall-clock limit but a generous one: CI is a busy machine).
        public static RunResult Run(string file, string arguments, int timeoutSeconds = 600, IDictionary<string, string> env = null)
        {
            using (Process p = Start(file, arguments, env))
            {
                var stdout = new StringBuilder();
                var stderr = new StringBuilder();
                p.OutputDataReceived += (s, e) => { if (e.Data != null) lock (stdout) stdout.AppendLine(e.Data); };
                p.ErrorDataReceived += (s, e) => { if (e.Data != null) lock (stderr) stderr.AppendLine(e.Data); };
                p.BeginOutputReadLine();
                p.BeginErrorReadLine();
                if (!p.WaitForExit(timeoutSeconds * 1000))
                {
                    p.Kill();
                    Assert.Fail($"{file} {arguments}: still running after {timeoutSeconds} s");
                }
                p.WaitForExit(); // flushes the asynchronous readers
                return new RunResult { ExitCode = p.ExitCode, Stdout = stdout.ToString(), Stderr = stderr.ToString() };
            }
        }

        public static Process Start(string file, string arguments, IDictionary<string, string> env = null)
        {
            var info = new ProcessStartInfo(file, arguments)
            {
                UseShellExecute = false, RedirectStandardOutput = true, RedirectStandardError = true,
            };
            if (env != null) foreach (var kv in env) info.EnvironmentVariables[kv.Key] = kv.Value;
            return Process.Start(info);
        }

        public static int FreeUdpPort()
        {
            using (var s = new Socket(AddressFamily.InterNetwork, SocketType.Dgram, ProtocolType.Udp))
            {
                s.Bind(new IPEndPoint(IPAddress.Loopback, 0));
                return ((IPEndPoint)s.LocalEndPoint).Port;
            }
        }

        public struct Stamped { public double Time; public Pose Pose; public string Line; }

        // A TUM trajectory: "t tx ty tz qx qy qz qw" per line, '#' comments.
        public static List<Stamped> ReadTum(string path)
        {
            var poses = new List<Stamped>();
            foreach (string raw in File.ReadAllLines(path))
            {
                string line = raw.Trim();
                if (line.Length == 0 || line[0] == '#') continue;
                string[] f = line.Split(new[] { ' ', '\t', ',' }, StringSplitOptions.RemoveEmptyEntries);
                Assert.AreEqual(8, f.Length, path + ": " + line);
                var v = new double[8];
                for (int i = 0; i < 8; ++i) v[i] = double.Parse(f[i], CultureInfo.InvariantCulture);
                poses.Add(new Stamped
                {
                    Time = v[0], Line = line,
                    Pose = new Pose(new Vec3(v[1], v[2], v[3]), new Quat(v[4], v[5], v[6], v[7])),
                });
            }
            return poses;
        }

        public static string TumLine(double t, Pose p) => string.Format(CultureInfo.InvariantCulture,
            "{0:F6} {1:F9} {2:F9} {3:F9} {4:F9} {5:F9} {6:F9} {7:F9}", t, p.Position.X, p.Position.Y, p.Position.Z,
            p.Rotation.X, p.Rotation.Y, p.Rotation.Z, p.Rotation.W);

        // The truth pose at a time (the twin writes headset and truth at the same stamps).
        public static Dictionary<long, Pose> ByMicroseconds(List<Stamped> poses)
        {
            var d = new Dictionary<long, Pose>();
            foreach (Stamped s in poses) d[(long)Math.Round(s.Time * 1e6)] = s.Pose;
            return d;
        }

        public static void Report(string line)
        {
            // Collected by the driver into the ctest log (the figures of the closing note).
            Console.WriteLine("[figure] " + line);
            string file = Environment.GetEnvironmentVariable("COLOC_UNITY_FIGURES");
            if (!string.IsNullOrEmpty(file)) lock (typeof(TestEnvironment)) File.AppendAllText(file, line + Environment.NewLine);
        }
    }
}
