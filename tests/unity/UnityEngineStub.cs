// The few UnityEngine signatures the package's MonoBehaviours use, without behaviour: lets mcs
// type-check Runtime/Unity outside Unity. Nothing here runs; the MonoBehaviours' behaviour
// needs Unity (the package README says so).
using System;

namespace UnityEngine
{
    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
    }

    public struct Quaternion
    {
        public float x, y, z, w;
        public Quaternion(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
        public static Quaternion Inverse(Quaternion q) => throw new NotImplementedException();
        public static Quaternion operator *(Quaternion a, Quaternion b) => throw new NotImplementedException();
    }

    public static class Mathf { public const float Deg2Rad = 0.0174532924f; }

    public class Object { }

    public class Component : Object { public Transform transform => throw new NotImplementedException(); }

    public class Transform : Component
    {
        public Vector3 position { get; set; }
        public Quaternion rotation { get; set; }
        public Vector3 localPosition { get; set; }
        public Quaternion localRotation { get; set; }
        public Vector3 TransformPoint(Vector3 p) => throw new NotImplementedException();
        public Vector3 InverseTransformPoint(Vector3 p) => throw new NotImplementedException();
        public void SetPositionAndRotation(Vector3 p, Quaternion q) => throw new NotImplementedException();
    }

    public class Behaviour : Component { public bool enabled { get; set; } }
    public class MonoBehaviour : Behaviour { }

    public static class Debug { public static void LogError(object message, Object context) { } }

    public sealed class TooltipAttribute : Attribute { public TooltipAttribute(string tooltip) { } }
    public sealed class ExecuteAlways : Attribute { }
    public sealed class DefaultExecutionOrder : Attribute { public DefaultExecutionOrder(int order) { } }
}
