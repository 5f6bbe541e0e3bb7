"""multipart/form-data bodies for the Python tests (the standard library has no encoder)."""
import io
import uuid


def multipart(parts):
    """parts: [(name, bytes or str, filename or None)] in order; returns (body, headers)."""
    boundary = uuid.uuid4().hex
    out = io.BytesIO()
    for name, data, filename in parts:
        out.write(f"--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"".encode())
        if filename:
            out.write(f"; filename=\"{filename}\"\r\nContent-Type: image/png".encode())
        out.write(b"\r\n\r\n")
        out.write(data if isinstance(data, bytes) else data.encode())
        out.write(b"\r\n")
    out.write(f"--{boundary}--\r\n".encode())
    return out.getvalue(), {"Content-Type": f"multipart/form-data; boundary={boundary}"}
