// The calibrations coloc writes, read without a YAML library (Unity has none built in), and the
// compositions that put heads, controllers and whole VR systems into the scan's frame. All
// poses here are in coloc's right-handed frames: convert the result with Frames.ScanToUnity.
//
// Files read:
//   `coloc handeye solve --output F.yaml`: device_from_marker: [16], vr_from_camera: [16],
//     sigma: s (4x4 row-major, metres; registration/handeye/io.hpp)
//   a headset mounting (the twin's headset/calibration.yaml, `coloc localize --cam-from-head`):
//     OpenCV YAML, cam_from_head (or cam_from_headset): !!opencv-matrix rows 4 cols 4 data [16]
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Text.RegularExpressions;

namespace Coloc
{
    public sealed class HandEyeCalibration
    {
        public Pose DeviceFromMarker;
        public Pose VrFromCamera;
        public double Sigma = 1.0;

        public static HandEyeCalibration Read(string path)
        {
            string text = ReadText(path);
            var c = new HandEyeCalibration
            {
                DeviceFromMarker = Pose.FromMatrix(Matrix(text, "device_from_marker", path)),
                VrFromCamera = Pose.FromMatrix(Matrix(text, "vr_from_camera", path)),
            };
            Match s = Regex.Match(text, @"^\s*sigma\s*:\s*([^\s#]+)", RegexOptions.Multiline);
            if (s.Success) c.Sigma = Number(s.Groups[1].Value, path, "sigma");
            return c;
        }

        // cam_from_head of a camera mounted on the headset (cam_from_headset accepted too).
        public static Pose ReadCamFromHead(string path)
        {
            string text = ReadText(path);
            string key = Regex.IsMatch(text, @"^\s*cam_from_head\s*:", RegexOptions.Multiline) ? "cam_from_head" : "cam_from_headset";
            return Pose.FromMatrix(Matrix(text, key, path));
        }

        // The 16 numbers after `key:`, either inline ([..]) or in an OpenCV matrix's data: [..].
        internal static double[] Matrix(string text, string key, string path)
        {
            Match m = Regex.Match(text, @"^\s*" + key + @"\s*:(.*?)(\[[^\]]*\])", RegexOptions.Multiline | RegexOptions.Singleline);
            if (!m.Success) throw new ColocException($"{path}: no key '{key}' with a [4x4 row-major] matrix");
            string[] fields = m.Groups[2].Value.Trim('[', ']').Split(new[] { ',', ' ', '\n', '\r', '\t' }, StringSplitOptions.RemoveEmptyEntries);
            if (fields.Length != 16) throw new ColocException($"{path}: '{key}' has {fields.Length} numbers, 16 expected (4x4 row-major)");
            var values = new double[16];
            for (int i = 0; i < 16; ++i) values[i] = Number(fields[i], path, key);
            return values;
        }

        static double Number(string s, string path, string key)
        {
            if (!double.TryParse(s, NumberStyles.Float, CultureInfo.InvariantCulture, out double v) || double.IsNaN(v) || double.IsInfinity(v))
                throw new ColocException($"{path}: '{key}': '{s}' is not a finite number");
            return v;
        }

        static string ReadText(string path)
        {
            try { return File.ReadAllText(path); }
            catch (Exception e) when (e is IOException || e is UnauthorizedAccessException)
            {
                throw new ColocException($"{path}: cannot read the calibration ({e.Message})", -1, e);
            }
        }
    }

    public static class Compose
    {
        // What the localizer publishes with --cam-from-head: world_from_cam * cam_from_head.
        public static Pose WorldFromHead(Pose worldFromCam, Pose camFromHead) => worldFromCam * camFromHead;

        // A controller relative to the head, both tracked by the same VR system.
        public static Pose HeadFromController(Pose vrFromHead, Pose vrFromController) => vrFromHead.Inverse * vrFromController;

        // ... and in the scan's frame once the head is (a fused pose).
        public static Pose WorldFromController(Pose worldFromHead, Pose headFromController) => worldFromHead * headFromController;

        // A whole VR system in the scan's frame from its hand-eye calibration to an anchor camera
        // that the localizer placed in the scan: world_from_camera * (vr_from_camera)^-1.
        public static Pose WorldFromVr(Pose worldFromCamera, Pose vrFromCamera) => worldFromCamera * vrFromCamera.Inverse;

        // `coloc handeye link A.yaml B.yaml`: vr_b_from_vr_a = vr_b_from_camera * camera_from_vr_a.
        public static Pose VrBFromVrA(Pose vrAFromCamera, Pose vrBFromCamera) => vrBFromCamera * vrAFromCamera.Inverse;

        // One registration's camera-to-VR transform (the paper's M_c2v, registration/handeye/
        // compose.hpp): vr_from_device * device_from_marker * (sigma-scaled camera_from_marker)^-1.
        public static Pose VrFromCamera(Pose vrFromDevice, Pose deviceFromMarker, Pose cameraFromMarker, double sigma = 1.0)
        {
            var scaled = new Pose(sigma * cameraFromMarker.Position, cameraFromMarker.Rotation);
            return vrFromDevice * deviceFromMarker * scaled.Inverse;
        }
    }
}
