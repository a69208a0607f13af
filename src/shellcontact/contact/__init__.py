"""Contact with rigid bodies: the punches, the contact operator (B, gap G, weights), the contact
zone's rim, floating shells. A friction law goes here, beside the operator.
"""
