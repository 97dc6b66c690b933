// Unity's float types <-> the core's double ones. Only copies: the change of frame is
// Coloc.Frames, done once, in the core (tested under mono).
using UnityEngine;

namespace Coloc.Unity
{
    public static class UnityPose
    {
        public static Vec3 ToCore(Vector3 v) => new Vec3(v.x, v.y, v.z);
        public static Quat ToCore(Quaternion q) => new Quat(q.x, q.y, q.z, q.w);
        public static Pose ToCore(Vector3 position, Quaternion rotation) => new Pose(ToCore(position), ToCore(rotation));

        public static Vector3 ToUnity(Vec3 v) => new Vector3((float)v.X, (float)v.Y, (float)v.Z);
        public static Quaternion ToUnity(Quat q) => new Quaternion((float)q.X, (float)q.Y, (float)q.Z, (float)q.W);
    }
}
