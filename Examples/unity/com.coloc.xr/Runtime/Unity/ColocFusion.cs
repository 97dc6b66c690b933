// Keeps a scan-anchored root where the laser scan really is around the user. Each frame: the
// global poses received over OSC (`coloc localize --publish osc.udp://THIS_PC:port`) go into
// the drift fusion, then the head's pose in the XR rig's tracking space; the fused world_from_head
// gives the scan's pose in tracking space, xr_from_world = xr_from_head * world_from_head^-1,
// which is applied to `scanRoot`. Unity's camera is never moved: the XR runtime owns it.
using System;
using UnityEngine;

namespace Coloc.Unity
{
    [DefaultExecutionOrder(-50)]
    public sealed class ColocFusion : MonoBehaviour
    {
        [Tooltip("The XR camera (its pose in trackingSpace is the headset's xr_from_head)")]
        public Transform head;
        [Tooltip("The XR rig's tracking space (XR Origin / Camera Offset)")]
        public Transform trackingSpace;
        [Tooltip("Parent of everything placed in the scan's frame (ColocAnchor children)")]
        public Transform scanRoot;
        [Tooltip("UDP port the localizer publishes /coloc/pose to")]
        public int listenPort = 9000;
        [Tooltip("127.0.0.1 for a localizer on this PC, 0.0.0.0 for one on the network")]
        public string bindAddress = "127.0.0.1";
        [Tooltip("Seconds added to this PC's Unix time to get the localizer's clock")]
        public double clockOffset = 0.0;

        public FusionState State { get; private set; }
        public OscClientStats OscStats => client != null ? client.Stats : default(OscClientStats);

        DriftFusion fusion;
        OscPoseClient client;

        void OnEnable()
        {
            try
            {
                fusion = new DriftFusion();
                client = new OscPoseClient(new OscClientOptions { BindAddress = bindAddress, Port = listenPort });
            }
            catch (ColocException e)
            {
                // A missing plugin or a port in use: said once, the component switched off.
                Debug.LogError("ColocFusion: " + e.Message, this);
                OnDisable();
                enabled = false;
            }
        }

        void OnDisable()
        {
            client?.Dispose();
            fusion?.Dispose();
            client = null;
            fusion = null;
        }

        // Update runs at the display rate, the headset's rate on device.
        void Update()
        {
            if (fusion == null) return;
            while (client.TryTake(out OscPose g))
                if (g.Address == OscCodec.PoseAddress) fusion.PushGlobalPose(g.Time, g.Pose, (TrackingState)g.State);

            // The head in tracking space, Unity's axes: converted to the scan's by the fusion.
            Pose xrFromHead = UnityPose.ToCore(trackingSpace.InverseTransformPoint(head.position),
                                               Quaternion.Inverse(trackingSpace.rotation) * head.rotation);
            double now = DateTimeOffset.UtcNow.ToUnixTimeMilliseconds() / 1000.0 + clockOffset;
            FusedPose fused = fusion.PushUnityXrPose(now, xrFromHead);
            State = fused.State;
            if (fused.State == FusionState.Waiting) return;

            Pose xrFromWorld = xrFromHead * fused.WorldFromHead.Inverse;
            scanRoot.SetPositionAndRotation(trackingSpace.TransformPoint(UnityPose.ToUnity(xrFromWorld.Position)),
                                            trackingSpace.rotation * UnityPose.ToUnity(xrFromWorld.Rotation));
        }
    }
}
