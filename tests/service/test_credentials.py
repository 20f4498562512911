"""Passwords at rest (service/credentials.py): argon2id at the library's recommended parameters,
a fresh salt per hash, and a check that tells the right password from a wrong one and refuses a
stored value that is no hash. (The other service tests hash each password once per process:
tests/conftest.py.)"""

from argon2 import PasswordHasher, extract_parameters

from service.credentials import hash_password, password_matches

PASSWORD = "correct horse battery"


def test_a_password_is_hashed_by_argon2id_with_a_fresh_salt_each_time():
    first, second = hash_password(PASSWORD), hash_password(PASSWORD)
    assert first.startswith("$argon2id$") and first != second  # the salt differs
    recommended = PasswordHasher()
    for stored in (first, second):
        p = extract_parameters(stored)
        assert (p.time_cost, p.memory_cost, p.parallelism) == (
            recommended.time_cost, recommended.memory_cost, recommended.parallelism)
        assert password_matches(stored, PASSWORD)
    assert not password_matches(first, PASSWORD + "!")
    assert not password_matches("not a hash", PASSWORD)
