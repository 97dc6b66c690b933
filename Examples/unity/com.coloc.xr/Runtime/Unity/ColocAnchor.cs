// Places this object at a pose given in the laser scan's frame (metres, right-handed, z up: the
// numbers a point-cloud viewer such as CloudCompare shows), under the ColocFusion scanRoot.
using UnityEngine;

namespace Coloc.Unity
{
    [ExecuteAlways]
    public sealed class ColocAnchor : MonoBehaviour
    {
        [Tooltip("Position in the scan's frame: x, y, z with z up, metres")]
        public Vector3 scanPosition;
        [Tooltip("Heading about the scan's z axis, degrees, counter-clockwise seen from above")]
        public float scanHeadingDegrees;

        void OnValidate() => Apply();
        void Start() => Apply();

        void Apply()
        {
            Quat heading = Quat.AxisAngle(new Vec3(0, 0, 1), scanHeadingDegrees * Mathf.Deg2Rad);
            Pose local = Frames.ScanToUnity(new Pose(UnityPose.ToCore(scanPosition), heading));
            transform.localPosition = UnityPose.ToUnity(local.Position);
            transform.localRotation = UnityPose.ToUnity(local.Rotation);
        }
    }
}
