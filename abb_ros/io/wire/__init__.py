"""Messages on the wire: CDR, message contents, definitions, topics, markers.

Also the joint-speed reader, which reads a few fields of ``joint_states`` from its CDR bytes.
"""
